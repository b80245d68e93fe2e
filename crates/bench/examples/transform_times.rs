//! Times every transformation at every strength on a mesh and prints a table.
//!
//! `cargo run --release -p keycomp-bench --example transform_times -- ../shared/data/kids/0001.null.0.off`

use std::path::PathBuf;
use std::time::Instant;

use keycomp_bench::{Kind, Pullback, transform};
use keycomp_mesh::{Topology, read_mesh};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .ok_or("usage: transform_times MESH")?;
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
