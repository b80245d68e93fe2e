//! Query an index with a file: a whole shape, a fragment, a range scan or a point cloud.
//!
//! ```text
//! cargo run --release -p keycomp --example query -- INDEX QUERY [K]
//! cargo run --release -p keycomp --example query          # a generated collection and scan
//! ```
//!
//! [`Searcher::open`] opens the index with the parameters it was built with; [`Searcher::query`]
//! reads the query, detects and describes it as the index's shapes were (a fragment under two
//! scale hypotheses), matches its parts to the indexed parts and ranks the shapes. This is what
//! `keycomp query INDEX QUERY -k K` does. Without arguments, the example indexes a generated
//! collection and queries it with what a range scanner sees of one of its shapes from one
//! direction: that shape should come first.

mod common;

use std::path::PathBuf;

use keycomp::collection::{self, AddOptions};
use keycomp::search::Searcher;
use keycomp_fragment::{PartialKind, cut_fragment};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let work = tempfile::tempdir()?;
    let (index, query, k) = match args.as_slice() {
        [index, query] => (PathBuf::from(index), PathBuf::from(query), 5),
        [index, query, k] => (PathBuf::from(index), PathBuf::from(query), k.parse()?),
        [] => {
            let folder = work.path().join("shapes");
            std::fs::create_dir(&folder)?;
            let files = common::generated_collection(&folder, 2)?;
            let index = work.path().join("index");
            collection::add(&index, &[folder], &AddOptions::default(), &())?;
            // a one-sided view of 40 % of the third shape's area, saved as a file
            let source = keycomp_mesh::read_mesh(&files[2])?.mesh;
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let scan = cut_fragment(&source, PartialKind::Scan, 0.4, &mut rng)?;
            let query = work.path().join("scan.off");
            keycomp_mesh::write_off(&scan.mesh, &query)?;
            println!("query: a scan of {}", files[2].display());
            (index, query, 5)
        }
        _ => return Err("usage: query [INDEX QUERY [K]]".into()),
    };
    // `None`: the index's own detection parameters
    let searcher = Searcher::open(&index, None)?;
    let answer = searcher.query(&query, k)?;
    println!(
        "{}: {} parts, answered in {:.0} ms",
        answer.query, answer.components, answer.timings_ms.total
    );
    for hit in &answer.results {
        let verified = hit
            .verified
            .map_or(String::from("-"), |v| format!("{:.0} %", 100.0 * v));
        println!(
            "{:>2}. {:.3}  verified {:>5}  {} matched parts  {}",
            hit.rank,
            hit.score,
            verified,
            hit.matches.len(),
            hit.path
        );
    }
    Ok(())
}
