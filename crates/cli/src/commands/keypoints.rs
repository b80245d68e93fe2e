//! `keycomp keypoints`: Harris 3D keypoints of one mesh file.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use keycomp_harris::HarrisParams;
use keycomp_mesh::{Topology, read_mesh};
use serde::Serialize;

use crate::args::HarrisArgs;
use crate::{colors, output};

pub const EXAMPLES: &str = "Examples:
  keycomp keypoints bunny.off
  keycomp keypoints horse.ply --count 50 --json > keypoints.json
  keycomp keypoints cat0.off --rings 3 --ply cat0-response.ply";

/// Arguments of `keycomp keypoints`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mesh file (.off, .obj, .ply, .stl, .gltf, .glb).
    pub mesh: PathBuf,
    #[command(flatten)]
    pub harris: HarrisArgs,
    /// Print JSON: {"mesh", "vertices", "faces", "keypoints" (best first), "response"}.
    #[arg(long)]
    pub json: bool,
    /// Write the mesh coloured by response (by rank) with keypoints in magenta, as binary PLY.
    #[arg(long, value_name = "OUT")]
    pub ply: Option<PathBuf>,
}

#[derive(Serialize)]
struct Report<'a> {
    mesh: String,
    vertices: usize,
    faces: usize,
    keypoints: &'a [u32],
    /// One value per vertex; `null` where there is no response.
    response: &'a [f64],
}

pub fn run(args: Args) -> Result<ExitCode> {
    let params = args.harris.params(HarrisParams::default());
    let loaded = read_mesh(&args.mesh)?;
    let mesh = &loaded.mesh;
    let topo = Topology::new(mesh);
    let result = keycomp_harris::detect(mesh, &topo, &params)
        .with_context(|| format!("{}: Harris 3D failed", args.mesh.display()))?;

    if let Some(out) = &args.ply {
        let mut cols = colors::by_rank(&result.response);
        colors::highlight(&mut cols, &topo, &result.keypoints);
        keycomp_mesh::write_ply_colored(mesh, &cols, out)?;
    }

    if args.json {
        output::print_json(&Report {
            mesh: args.mesh.display().to_string(),
            vertices: mesh.num_vertices(),
            faces: mesh.num_faces(),
            keypoints: &result.keypoints,
            response: &result.response,
        })?;
    } else {
        let mut s = String::new();
        writeln!(
            s,
            "{}: {} vertices, {} faces",
            args.mesh.display(),
            mesh.num_vertices(),
            mesh.num_faces()
        )?;
        let r = &loaded.repairs;
        if r.dropped_faces() > 0 || r.unreferenced_vertices > 0 {
            writeln!(
                s,
                "  repaired: {} faces with a repeated vertex and {} zero-area faces dropped; {} unreferenced vertices ignored",
                r.repeated_index_faces, r.zero_area_faces, r.unreferenced_vertices
            )?;
        }
        writeln!(s, "{} keypoints, best first:", result.keypoints.len())?;
        writeln!(
            s,
            "{:>5}  {:>8}  {:>12}  {:>12} {:>12} {:>12}",
            "rank", "vertex", "response", "x", "y", "z"
        )?;
        const SHOWN: usize = 20;
        for (rank, &v) in result.keypoints.iter().take(SHOWN).enumerate() {
            let p = mesh.positions[v as usize];
            writeln!(
                s,
                "{:>5}  {:>8}  {:>12.5e}  {:>12.5} {:>12.5} {:>12.5}",
                rank + 1,
                v,
                result.response[v as usize],
                p.x,
                p.y,
                p.z
            )?;
        }
        if result.keypoints.len() > SHOWN {
            writeln!(
                s,
                "  … {} more (--json lists them all)",
                result.keypoints.len() - SHOWN
            )?;
        }
        if let Some(out) = &args.ply {
            writeln!(s, "wrote {}", out.display())?;
        }
        output::print_text(&s)?;
    }
    Ok(ExitCode::SUCCESS)
}
