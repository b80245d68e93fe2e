//! Times every transformation at every strength on a mesh and prints a table.
//!
//! `cargo bench -p keycomp-bench --bench transform_times -- ../shared/data/kids/0001.null.0.off`
//! (the mesh's path relative to the workspace root; without a mesh, or when `cargo bench` did not
//! run it, it prints its usage and measures nothing)

use std::time::Instant;

use keycomp_bench::{Kind, Pullback, transform};
use keycomp_mesh::{Topology, read_mesh};
use keycomp_test_support::{bench_args, workspace_path};

const USAGE: &str = "cargo bench -p keycomp-bench --bench transform_times -- MESH";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args(USAGE) else {
        return Ok(());
    };
    let Some(path) = args.get(1) else {
        eprintln!("usage: {USAGE}");
        return Ok(());
    };
    // `cargo bench` runs in crates/bench
    let path = workspace_path(path);
    let null = read_mesh(&path)?.mesh;
    let topo = Topology::new(&null);
    println!(
        "{}: {} vertices, {} faces",
        path.display(),
        null.num_vertices(),
        null.num_faces()
    );
    println!(
        "{:<11} {:>2} {:>9} {:>9} {:>10} {:>10}",
        "kind", "S", "vertices", "faces", "ms", "pullback ms"
    );
    for kind in Kind::ALL {
        for s in 1..=5u8 {
            let t0 = Instant::now();
            let result = transform(&null, kind, s, 1);
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            match result {
                Ok(t) => {
                    let t1 = Instant::now();
                    let _p = Pullback::new(&null, &topo, &t.map)?;
                    let pms = t1.elapsed().as_secs_f64() * 1e3;
                    println!(
                        "{:<11} {:>2} {:>9} {:>9} {:>10.1} {:>10.1}",
                        kind.name(),
                        s,
                        t.mesh.num_vertices(),
                        t.mesh.num_faces(),
                        ms,
                        pms
                    );
                }
                Err(e) => println!("{:<11} {:>2} error after {ms:.1} ms: {e}", kind.name(), s),
            }
        }
    }
    Ok(())
}
