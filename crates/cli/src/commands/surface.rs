//! `keycomp surface INPUT -o OUT.off`: the canonical surface keycomp analyses instead of the
//! file (`keycomp_surface`): one connected surface of a fixed density relative to the input's
//! size, for a mesh, a triangle soup, a range scan or a point cloud.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use keycomp::analysis::canonical_surface;
use keycomp_mesh::{Geometry, Topology, read_input, write_off};
use keycomp_surface::SurfaceParams;
use serde::Serialize;

use crate::output;

pub const EXAMPLES: &str = "Examples:
  keycomp surface chair.off -o chair-surface.off
  keycomp surface bun000.ply -o scan.off --json          # a range scan
  keycomp surface cloud.xyz -o cloud.off --vertices 20000";

/// Arguments of `keycomp surface`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mesh, range scan or point cloud file.
    pub input: PathBuf,
    /// Output OFF file.
    #[arg(short = 'o', long = "out", value_name = "OUT.off")]
    pub out: PathBuf,
    /// Vertices the surface aims at [default: the analysis's, 10,000].
    #[arg(long)]
    pub vertices: Option<usize>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// What `keycomp surface` prints.
#[derive(Debug, Serialize)]
struct Summary {
    input: String,
    input_vertices: usize,
    input_faces: usize,
    vertices: usize,
    faces: usize,
    boundary_vertices: usize,
    pieces: usize,
    /// Whether the input was reconstructed from an offset volume before remeshing (a soup, a
    /// cloud, pieces that touch), rather than remeshed on its own faces.
    reconstructed: bool,
    area: f64,
    warnings: Vec<String>,
    out: String,
}

pub fn run(args: Args) -> Result<ExitCode> {
    let params = SurfaceParams {
        vertices: args.vertices.unwrap_or(SurfaceParams::default().vertices),
        ..SurfaceParams::default()
    };
    let loaded = read_input(&args.input)?;
    let (input_vertices, input_faces) = match &loaded.geometry {
        Geometry::Mesh(m) => (m.num_vertices(), m.num_faces()),
        Geometry::Points(c) => (c.positions.len(), 0),
    };
    let surface = canonical_surface(&loaded.geometry, &params)
        .with_context(|| format!("{}: no canonical surface", args.input.display()))?;
    let mesh = surface.mesh;
    write_off(&mesh, &args.out)?;
    let topo = Topology::new(&mesh);
    let summary = Summary {
        input: args.input.display().to_string(),
        input_vertices,
        input_faces,
        vertices: mesh.num_vertices(),
        faces: mesh.num_faces(),
        boundary_vertices: topo.boundary_vertices().len(),
        pieces: topo.connected_components().1,
        reconstructed: surface.reconstructed,
        area: keycomp_mesh::geometry::total_area(&mesh),
        warnings: loaded.warnings,
        out: args.out.display().to_string(),
    };
    for w in &summary.warnings {
        eprintln!("warning: {}: {w}", args.input.display());
    }
    if args.json {
        output::print_json(&summary)?;
    } else {
        output::print_text(&format!(
            "{}: {} vertices, {} faces -> {}: {} vertices, {} faces, {} piece(s), {} boundary vertices ({})\n",
            summary.input,
            summary.input_vertices,
            summary.input_faces,
            summary.out,
            summary.vertices,
            summary.faces,
            summary.pieces,
            summary.boundary_vertices,
            if summary.reconstructed {
                "reconstructed from an offset volume"
            } else {
                "remeshed on its own faces"
            }
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}
