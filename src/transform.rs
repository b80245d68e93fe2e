//! `keycomp transform`: one SHREC'10-style transformation of a null mesh, with its
//! ground-truth correspondence (`keycomp_bench::transform`; parameters per kind and strength
//! in docs/transformations.md).

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use keycomp_bench::{Kind, transform, write_map};
use keycomp_mesh::{read_mesh, write_off};
use serde::Serialize;

use crate::output;

pub const EXAMPLES: &str = "Examples:
  keycomp transform cat0.off --kind holes --strength 3 -o cat0-holes-3.off
  keycomp transform cat0.off --kind sampling --strength 5 --seed 7 -o out/cat0-s5.off --map out/cat0-s5.map

Kinds: holes, microholes, noise, shotnoise, scale, localscale, topology, sampling; the parameters
of each kind per strength are in docs/transformations.md. The map file has a header line
'# keycomp-map v1 transformed=N null=M' and then one line per output vertex: the id of the null
vertex it comes from, or -1. Output meshes are written as OFF.";

/// Arguments of `keycomp transform`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The null mesh (.off, .obj, .ply, .stl).
    pub mesh: PathBuf,
    /// Transformation: holes, microholes, noise, shotnoise, scale, localscale, topology,
    /// sampling.
    #[arg(long, value_parser = parse_kind)]
    pub kind: Kind,
    /// Strength, 1 (mildest) to 5 (strongest).
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=5))]
    pub strength: u8,
    /// Seed of the random choices (hole centres, noise, …); same seed, same output.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output mesh (.off).
    #[arg(short = 'o', long = "output", value_name = "OUT_MESH")]
    pub output: PathBuf,
    /// Correspondence file [default: OUT_MESH with the extension .map].
    #[arg(long, value_name = "OUT_MAP")]
    pub map: Option<PathBuf>,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    pub json: bool,
}

fn parse_kind(s: &str) -> Result<Kind, String> {
    s.parse::<Kind>().map_err(|e| e.to_string())
}

#[derive(Serialize)]
struct Summary<'a> {
    null: String,
    kind: &'a str,
    strength: u8,
    seed: u64,
    null_vertices: usize,
    mesh: String,
    vertices: usize,
    faces: usize,
    map: String,
    unmapped: usize,
}

/// A temporary sibling of `path` (same folder, so renaming is atomic).
fn temp_sibling(path: &Path, tag: &str) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{tag}-{}.tmp", std::process::id()))
}

/// Checks that `path`'s folder exists, so that nothing is computed for an output that cannot
/// be written.
fn check_folder(path: &Path) -> Result<()> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        bail!(
            "{}: cannot write here: the folder {} does not exist",
            path.display(),
            parent.display()
        );
    }
    Ok(())
}

pub fn run(args: Args) -> Result<ExitCode> {
    let out = &args.output;
    let is_off = out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("off"));
    if !is_off {
        bail!(
            "{}: unsupported output format: keycomp transform writes OFF meshes; give the output \
             a .off extension",
            out.display()
        );
    }
    let map_path = args
        .map
        .clone()
        .unwrap_or_else(|| out.with_extension("map"));
    if map_path == *out {
        bail!(
            "{}: the map and the mesh would be the same file; give --map another name",
            map_path.display()
        );
    }
    check_folder(out)?;
    check_folder(&map_path)?;

    let null = read_mesh(&args.mesh)?.mesh;
    let t = transform(&null, args.kind, args.strength, args.seed).with_context(|| {
        format!(
            "{}: cannot apply {} at strength {}",
            args.mesh.display(),
            args.kind,
            args.strength
        )
    })?;

    // both files go to temporaries first and are renamed only when both are complete
    let mesh_tmp = temp_sibling(out, "mesh");
    let map_tmp = temp_sibling(&map_path, "map");
    let written = (|| -> Result<()> {
        write_off(&t.mesh, &mesh_tmp)
            .with_context(|| format!("{}: cannot write", out.display()))?;
        write_map(&t.map, null.num_vertices(), &map_tmp)
            .with_context(|| format!("{}: cannot write", map_path.display()))?;
        fs::rename(&mesh_tmp, out).with_context(|| format!("{}: cannot write", out.display()))?;
        if let Err(e) = fs::rename(&map_tmp, &map_path) {
            let _ = fs::remove_file(out);
            return Err(e).with_context(|| format!("{}: cannot write", map_path.display()));
        }
        Ok(())
    })();
    if written.is_err() {
        let _ = fs::remove_file(&mesh_tmp);
        let _ = fs::remove_file(&map_tmp);
    }
    written?;

    let summary = Summary {
        null: args.mesh.display().to_string(),
        kind: args.kind.name(),
        strength: args.strength,
        seed: args.seed,
        null_vertices: null.num_vertices(),
        mesh: out.display().to_string(),
        vertices: t.mesh.num_vertices(),
        faces: t.mesh.num_faces(),
        map: map_path.display().to_string(),
        unmapped: t.map.iter().filter(|m| m.is_none()).count(),
    };
    if args.json {
        output::print_json(&summary)?;
    } else {
        let mut s = String::new();
        writeln!(
            s,
            "{}: {} strength {} (seed {}): {} → {} vertices, {} faces",
            summary.null,
            summary.kind,
            summary.strength,
            summary.seed,
            summary.null_vertices,
            summary.vertices,
            summary.faces
        )?;
        writeln!(
            s,
            "wrote {} and {} ({} entries, {} without a null vertex)",
            summary.mesh, summary.map, summary.vertices, summary.unmapped
        )?;
        output::print_text(&s)?;
    }
    Ok(ExitCode::SUCCESS)
}
