//! How index open time and component search time grow with the number of shapes.
//!
//! Builds synthetic indexes (D = 32, 4–8 components per shape, descriptors uniform in
//! [0, 1)^32 from ChaCha8 with a fixed seed) of each size, then measures:
//! - open: `IndexReader::open` (median of several): read, checksum, decode all segments;
//! - tree build: the KD-tree, built on the first search (`prepare_search`);
//! - query: one `nearest_components(k = 10)` call, mean over 200 random query descriptors;
//! - shape query: `nearest_components_batch` of 10 descriptors with k = 10 (what a query mesh
//!   with 10 key-components costs), mean over 20.
//!
//! Prints a markdown table.
//!
//! ```text
//! cargo bench -p keycomp-index --bench index_scale -- [SIZES] [DIR|-] [BATCH]
//! ```
//! SIZES is comma-separated (default `1000,10000,100000`); DIR (kept afterwards; a relative
//! path is taken from the workspace root) defaults to a temp directory, removed afterwards
//! (`-`); BATCH is the number of shapes per `add_batch` (one segment each; default 1000). The
//! `--bench` flag that `cargo bench` passes is ignored; without it nothing is measured.

use std::time::{Duration, Instant};

use keycomp_index::{IndexReader, IndexWriter, synthetic};
use keycomp_test_support::{bench_args, median, workspace_path};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const D: usize = 32;
const SEED: u64 = 42;

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) =
        bench_args("cargo bench -p keycomp-index --bench index_scale -- [SIZES] [DIR|-] [BATCH]")
    else {
        return Ok(());
    };
    let args = &args[1..];
    let sizes: Vec<u64> = match args.first() {
        Some(s) => s
            .split(',')
            .map(|x| x.trim().parse())
            .collect::<Result<_, _>>()?,
        None => vec![1_000, 10_000, 100_000],
    };
    let base = match args.get(1) {
        Some(d) if d != "-" => workspace_path(d),
        _ => std::env::temp_dir().join(format!("keycomp-index-scale-{}", std::process::id())),
    };
    let keep = matches!(args.get(1), Some(d) if d != "-");
    let batch: u64 = match args.get(2) {
        Some(b) => b.parse()?,
        None => 1000,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(SEED + 1);
    println!(
        "| shapes | segments | components | index size | write (s) | open (ms) | tree build (ms) | query k=10 (ms) | shape query 10×k=10 (ms) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &n in &sizes {
        let dir = base.join(format!("n{n}"));
        if dir.exists() {
            std::fs::remove_dir_all(&dir)?;
        }
        let t = Instant::now();
        let mut w = IndexWriter::<D>::create_or_open(&dir)?;
        let mut i = 0;
        while i < n {
            let end = (i + batch).min(n);
            w.add_batch(synthetic::records::<D>(SEED, i..end))?;
            i = end;
        }
        drop(w);
        let write = t.elapsed();

        let reps = if n >= 100_000 { 3 } else { 7 };
        let mut opens = Vec::new();
        let mut trees = Vec::new();
        let mut reader = None;
        for _ in 0..reps {
            let t = Instant::now();
            let r = IndexReader::<D>::open(&dir)?;
            opens.push(ms(t.elapsed()));
            let t = Instant::now();
            r.prepare_search();
            trees.push(ms(t.elapsed()));
            reader = Some(r);
        }
        let Some(r) = reader else { continue };
        let stats = r.stats();

        let queries: Vec<[f32; D]> = (0..200)
            .map(|_| std::array::from_fn(|_| rng.random::<f32>()))
            .collect();
        let t = Instant::now();
        let mut found = 0;
        for q in &queries {
            found += r.nearest_components(q, 10)?.len();
        }
        let per_query = t.elapsed() / queries.len() as u32;
        assert_eq!(found, 10 * queries.len());

        let t = Instant::now();
        for c in queries.chunks(10).take(20) {
            let lists = r.nearest_components_batch(c, 10)?;
            assert!(lists.iter().all(|l| l.len() == 10));
        }
        let per_shape_query = t.elapsed() / 20;

        println!(
            "| {} | {} | {} | {:.1} MB | {:.2} | {:.1} | {:.1} | {:.2} | {:.1} |",
            stats.shapes,
            stats.segments,
            stats.components,
            stats.bytes as f64 / 1e6,
            write.as_secs_f64(),
            median(opens),
            median(trees),
            ms(per_query),
            ms(per_shape_query),
        );
        drop(r);
        if !keep {
            std::fs::remove_dir_all(&dir)?;
        }
    }
    if !keep {
        let _ = std::fs::remove_dir_all(&base);
    }
    Ok(())
}
