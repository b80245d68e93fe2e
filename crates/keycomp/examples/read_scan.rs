//! Read a range scan or a point cloud and find its key-components.
//!
//! ```text
//! cargo run --release -p keycomp --example read_scan -- SCAN    # .ply range grid, .pcd, .xyz, …
//! cargo run --release -p keycomp --example read_scan            # a generated one-sided scan
//! ```
//!
//! [`keycomp_mesh::read_input`] reads what a file holds: a mesh, a range grid (triangulated) or
//! points without faces. A scan has ragged borders, holes and the scanner's sampling, so it is
//! analysed on its canonical surface (`keycomp_surface`: a surface rebuilt from the points at a
//! fixed vertex budget), as `keycomp detect --canonical` and queries on a canonical index do;
//! detection (Sipiran & Bustos 2013) and description then run on that surface.

mod common;

use std::io::Write;
use std::path::PathBuf;

use keycomp::options::DetectOptions;
use keycomp::{Profile, Role};
use keycomp_fragment::{PartialKind, cut_fragment};
use keycomp_mesh::Geometry;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let work = tempfile::tempdir()?;
    let scan = match args.as_slice() {
        [scan] => scan.clone(),
        [] => {
            // the points a scanner sees of a generated shape from one direction, as `x y z` lines
            let files = common::generated_collection(work.path(), 1)?;
            let shape = keycomp_mesh::read_mesh(&files[1])?.mesh;
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let view = cut_fragment(&shape, PartialKind::Scan, 0.45, &mut rng)?;
            let path = work.path().join("view.xyz");
            let mut text = Vec::new();
            for p in &view.mesh.positions {
                writeln!(text, "{} {} {}", p.x, p.y, p.z)?;
            }
            std::fs::write(&path, text)?;
            path
        }
        _ => return Err("usage: read_scan [SCAN]".into()),
    };
    let loaded = keycomp_mesh::read_input(&scan)?;
    match &loaded.geometry {
        Geometry::Mesh(m) => println!(
            "{}: a mesh of {} vertices and {} triangles",
            scan.display(),
            m.num_vertices(),
            m.num_faces()
        ),
        Geometry::Points(p) => println!(
            "{}: {} points without faces",
            scan.display(),
            p.num_points()
        ),
    }
    for w in &loaded.warnings {
        println!("  reader: {w}");
    }
    let profile = Profile::current(&DetectOptions::default().retrieval_params())
        .with_surface(Some(keycomp_surface::SurfaceParams::default()));
    let analysed = keycomp::analyse_as(&scan, &profile, Role::Query)?;
    println!(
        "canonical surface: {} vertices; {} key-components, {} parts described, {:.0} ms",
        analysed.mesh.num_vertices(),
        analysed.detection.components.len(),
        analysed.description.components.len(),
        analysed.ms
    );
    Ok(())
}
