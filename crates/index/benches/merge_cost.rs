//! What `IndexWriter::merge` costs: builds SHARDS synthetic shard indexes of PER shapes each
//! (D = 64, the product's descriptor length; every shape given PARTS parts, the product's
//! average on Watertight being 84, with descriptors and layout from a fixed seed), then merges
//! them into an empty index and reports the time (median of RUNS merges into fresh
//! destinations), the shapes per second and the bytes written.
//!
//! ```text
//! cargo bench -p keycomp-index --bench merge_cost -- [SHARDS] [PER] [PARTS] [RUNS]
//! ```
//! Defaults: 4 shards of 2,500 shapes, 84 parts, 3 runs. The `--bench` flag that `cargo bench`
//! passes is ignored; without it nothing is measured.

use std::time::Instant;

use keycomp_index::{IndexReader, IndexWriter, ShapeRecord, synthetic};
use keycomp_test_support::{bench_args, median};

const D: usize = 64;

/// Argument `i` of `args` (the bench's name first) as a number, or `default`.
fn arg(args: &[String], i: usize, default: usize) -> usize {
    args.get(i).and_then(|a| a.parse().ok()).unwrap_or(default)
}

/// Synthetic record `i` grown to `parts` parts (its own parts repeated) with an m×m layout.
fn record(i: u64, parts: usize) -> ShapeRecord<D> {
    let mut r = synthetic::record::<D>(11, i);
    let base = r.components.clone();
    r.components = (0..parts).map(|k| base[k % base.len()].clone()).collect();
    r.layout = (0..parts * parts)
        .map(|k| if k / parts == k % parts { 0.0 } else { 0.5 })
        .collect();
    r
}

fn size_of_dir(dir: &std::path::Path) -> u64 {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok()?.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args(
        "cargo bench -p keycomp-index --bench merge_cost -- [SHARDS] [PER] [PARTS] [RUNS]",
    ) else {
        return Ok(());
    };
    let (shards, per, parts, runs) = (
        arg(&args, 1, 4),
        arg(&args, 2, 2500),
        arg(&args, 3, 84),
        arg(&args, 4, 3),
    );
    let tmp = tempfile::tempdir()?;
    let mut dirs = Vec::new();
    for s in 0..shards {
        let dir = tmp.path().join(format!("shard-{s}"));
        let mut w = IndexWriter::<D>::create_or_open(&dir)?;
        w.ensure_profile("merge_cost")?;
        let start = (s * per) as u64;
        for chunk in (start..start + per as u64).collect::<Vec<_>>().chunks(500) {
            w.add_batch(chunk.iter().map(|&i| record(i, parts)).collect())?;
        }
        dirs.push(dir);
    }
    let shard_bytes: u64 = dirs.iter().map(|d| size_of_dir(d)).sum();
    let mut open_ms = Vec::new();
    let mut merge_ms = Vec::new();
    let mut out_bytes = 0;
    for run in 0..runs {
        let t = Instant::now();
        let sources: Vec<IndexReader<D>> = dirs
            .iter()
            .map(IndexReader::<D>::open)
            .collect::<Result<_, _>>()?;
        open_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let dst = tmp.path().join(format!("merged-{run}"));
        let t = Instant::now();
        let mut w = IndexWriter::<D>::create_or_open(&dst)?;
        let s = w.merge(&sources)?;
        merge_ms.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(s.added, shards * per);
        out_bytes = size_of_dir(&dst);
    }
    let (o, m) = (median(open_ms), median(merge_ms));
    let shapes = shards * per;
    println!(
        "| shards | shapes | parts per shape | shard bytes | open sources ms | merge ms | shapes/s (merge) | bytes written |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "| {shards} | {shapes} | {parts} | {shard_bytes} | {o:.0} | {m:.0} | {:.0} | {out_bytes} |",
        shapes as f64 / (m / 1e3)
    );
    Ok(())
}
