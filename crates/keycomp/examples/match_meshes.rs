//! Match two meshes part to part.
//!
//! ```text
//! cargo run --release -p keycomp --example match_meshes -- A B
//! cargo run --release -p keycomp --example match_meshes   # a generated shape and a piece of it
//! ```
//!
//! [`match_files`] analyses both files (A as a query: a fragment is described under two scale
//! hypotheses) and pairs A's parts with B's (Sipiran & Bustos 2013's key-components, described
//! by their Harris response and geodesic statistics, matched one to one). This is what
//! `keycomp match A B` does.

mod common;

use std::path::PathBuf;

use keycomp::matching::{MatchOptions, match_files};
use keycomp_fragment::{PartialKind, cut_fragment};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let work = tempfile::tempdir()?;
    let (a, b) = match args.as_slice() {
        [a, b] => (a.clone(), b.clone()),
        [] => {
            let files = common::generated_collection(work.path(), 1)?;
            // half of the first shape, cut by a plane, against the whole shape
            let whole = keycomp_mesh::read_mesh(&files[0])?.mesh;
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let half = cut_fragment(&whole, PartialKind::Plane, 0.5, &mut rng)?;
            let a = work.path().join("half.off");
            keycomp_mesh::write_off(&half.mesh, &a)?;
            (a, files[0].clone())
        }
        _ => return Err("usage: match_meshes [A B]".into()),
    };
    let (x, y, m) = match_files(&a, &b, &MatchOptions::default())?;
    println!(
        "{}: {} parts ({} key-components); {}: {} parts ({} key-components)",
        m.a,
        m.components_a,
        x.detection.components.len(),
        m.b,
        m.components_b,
        y.detection.components.len()
    );
    let verified = m
        .verified
        .map_or(String::from("-"), |v| format!("{:.0} %", 100.0 * v));
    println!(
        "score {:.3}, {} pairs kept, {} rejected, verified {verified}",
        m.score,
        m.matches.len(),
        m.rejected
    );
    for pair in &m.matches {
        println!(
            "A part {:>3}  <->  B part {:>3}   distance {:.3}",
            pair.a_component, pair.b_component, pair.distance
        );
    }
    Ok(())
}
