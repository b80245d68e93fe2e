//! Index open time and query latency (excluding the query's own detection) as the index grows.
//! Shapes are synthetic records (4–8 components, random descriptors, `keycomp_index::synthetic`)
//! or, given an index of real shapes, copies of its records with every descriptor value moved by
//! up to ±0.01 (so a 200-shape index of about 90 parts per shape grows to any size with
//! realistic descriptors); queries are indexed shapes' descriptors and layout, perturbed alike.
//!
//! `cargo run --release -p keycomp-retrieval --example query_scale -- [SIZES] [INDEX]`
//! (SIZES: comma-separated shape counts, default 1000,10000,100000; INDEX: an index directory to
//! take records from). Prints a markdown table.

use std::time::Instant;

use keycomp_describe::DIM;
use keycomp_index::{IndexReader, IndexWriter, synthetic};
use keycomp_retrieval::{MatchParams, rank};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let sizes: Vec<u64> = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "1000,10000,100000".into())
        .split(',')
        .map(|s| s.trim().parse())
        .collect::<Result<_, _>>()?;
    let source: Option<Vec<keycomp_index::ShapeRecord<DIM>>> = match std::env::args().nth(2) {
        Some(dir) => Some(
            IndexReader::<DIM>::open(&dir)?
                .shapes()
                .iter()
                .map(|s| s.record.clone())
                .collect(),
        ),
        None => None,
    };
    let mut jitter = ChaCha8Rng::seed_from_u64(2);
    let mut records = |range: std::ops::Range<u64>| -> Vec<keycomp_index::ShapeRecord<DIM>> {
        match &source {
            None => synthetic::records(7, range),
            Some(src) if !src.is_empty() => range
                .map(|i| {
                    let mut r = src[i as usize % src.len()].clone();
                    let name = format!("copy-{i:07}.off");
                    r.path = std::path::PathBuf::from("copies").join(&name);
                    r.canonical_path = std::path::PathBuf::from("/copies").join(&name);
                    r.content_hash = keycomp_index::ContentHash::of_bytes(&i.to_le_bytes());
                    for c in &mut r.components {
                        for x in &mut c.descriptor {
                            *x += jitter.random_range(-0.01..0.01);
                        }
                    }
                    r
                })
                .collect(),
            Some(_) => Vec::new(),
        }
    };
    println!(
        "| shapes | components | open (ms) | first query incl. KD-tree build (ms) | query (ms, median of 20) |"
    );
    println!("|---:|---:|---:|---:|---:|");
    for n in sizes {
        let dir = tempfile::tempdir()?;
        {
            let mut w = IndexWriter::<DIM>::create_or_open(dir.path())?;
            let mut i = 0;
            while i < n {
                let end = (i + 5000).min(n);
                w.add_batch(records(i..end))?;
                i = end;
            }
        }
        let mut opens = Vec::new();
        for _ in 0..5 {
            let t = Instant::now();
            let r = IndexReader::<DIM>::open(dir.path())?;
            opens.push(t.elapsed().as_secs_f64() * 1e3);
            drop(r);
        }
        let reader = IndexReader::<DIM>::open(dir.path())?;
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let make_query = |rng: &mut ChaCha8Rng| {
            let id = reader.shapes()[rng.random_range(0..reader.shapes().len())].id;
            let rec = reader.get(id).cloned();
            rec.map(|rec| {
                let descs: Vec<[f32; DIM]> = rec
                    .components
                    .iter()
                    .map(|c| {
                        let mut d = c.descriptor;
                        for x in &mut d {
                            *x += rng.random_range(-0.01..0.01);
                        }
                        d
                    })
                    .collect();
                (descs, rec.layout)
            })
        };
        let params = MatchParams::default();
        let (d0, l0) = make_query(&mut rng).ok_or("empty index")?;
        let t = Instant::now();
        rank(&reader, &d0, &l0, 10, &params)?;
        let first = t.elapsed().as_secs_f64() * 1e3;
        let mut times = Vec::new();
        for _ in 0..20 {
            let (d, l) = make_query(&mut rng).ok_or("empty index")?;
            let t = Instant::now();
            let r = rank(&reader, &d, &l, 10, &params)?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
            assert!(!r.is_empty());
        }
        println!(
            "| {n} | {} | {:.1} | {:.1} | {:.2} |",
            reader.component_count(),
            median(opens),
            first,
            median(times)
        );
    }
    Ok(())
}
