//! `keycomp transform`: one SHREC'10-style transformation of a null mesh, with its
//! ground-truth correspondence (`keycomp_bench::transform`; parameters per kind and strength
//! in docs/transformations.md).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use keycomp_bench::{Kind, format_map, transform};
use keycomp_mesh::io::output::Output;
use keycomp_mesh::{read_mesh, write_off_to};
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
    /// The null mesh (.off, .obj, .ply, .stl, .gltf, .glb).
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

/// Resolves and checks an output path before anything is computed for it.
fn output_at(path: &Path) -> Result<Output> {
    Output::new(path).with_context(|| format!("{}: cannot write here", path.display()))
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
    let mesh_out = output_at(out)?;
    let map_out = output_at(&map_path)?;
    if mesh_out.target() == map_out.target() {
        bail!(
            "{}: the map and the mesh would be the same file; give --map another name",
            map_path.display()
        );
    }

    let null = read_mesh(&args.mesh)?.mesh;
    let t = transform(&null, args.kind, args.strength, args.seed).with_context(|| {
        format!(
            "{}: cannot apply {} at strength {}",
            args.mesh.display(),
            args.kind,
            args.strength
        )
    })?;

    // Both files are staged (temporary files, or memory for a FIFO or device) and put in
    // place only when both are complete.
    let map_text = format_map(&t.map, null.num_vertices())
        .with_context(|| format!("{}: cannot write", map_path.display()))?;
    let mesh_staged = mesh_out
        .stage(|w| write_off_to(&t.mesh, w))
        .with_context(|| format!("{}: cannot write", out.display()))?;
    let map_staged = map_out
        .stage(|w| w.write_all(map_text.as_bytes()))
        .with_context(|| format!("{}: cannot write", map_path.display()))?;
    mesh_staged
        .commit()
        .with_context(|| format!("{}: cannot write", out.display()))?;
    map_staged
        .commit()
        .with_context(|| format!("{}: cannot write", map_path.display()))?;

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
