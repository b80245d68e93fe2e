//! The index's inverted file (`keycomp_index`, the default search from
//! `keycomp_index::IVF_MIN_COMPONENTS` parts) against an HNSW graph from a maintained crate
//! (`hnsw_rs`: Y. A. Malkov and D. A. Yashunin, "Efficient and robust approximate nearest
//! neighbor search using Hierarchical Navigable Small World graphs", IEEE TPAMI 42(4), 2020)
//! on the same part descriptors and query parts, in one run: the time to build each, the memory
//! each holds, the search of a query's parts (`CANDIDATES_PER_COMPONENT` neighbours each, the
//! parts searched in parallel by both) and recall against the exact search (the KD-tree,
//! `SearchMode::Exact`): the share of each part's exact neighbours that are found.
//!
//! `cargo bench -p keycomp-retrieval --bench ann_compare -- SHAPES INDEX [QUERIES]`
//! (SHAPES: shapes to grow the index to; INDEX: an index of real shapes whose records are
//! copied with every descriptor value moved by up to ±0.01, as `query_scale` grows them;
//! QUERIES: query shapes, default 20, each an indexed shape's parts moved alike). Prints a
//! markdown table; medians over the query shapes.
//! Relative paths, on the command line and in the environment, are taken from the workspace
//! root.

use std::time::Instant;

mod common;
use common::{env_path, grown_copy, resident_mb};
use hnsw_rs::prelude::{DistL2, Hnsw};
use keycomp_describe::DIM;
use keycomp_index::{IndexReader, IndexWriter, SearchMode, ShapeId, ShapeRecord};
use keycomp_retrieval::CANDIDATES_PER_COMPONENT;
use keycomp_test_support::{bench_args, median, workspace_path};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Share of `want`'s (shape, part) pairs found in `got`.
fn recall(got: &[(ShapeId, usize)], want: &[(ShapeId, usize)]) -> f64 {
    if want.is_empty() {
        return 1.0;
    }
    let found = want.iter().filter(|w| got.contains(w)).count();
    found as f64 / want.len() as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args(
        "cargo bench -p keycomp-retrieval --bench ann_compare -- SHAPES INDEX [QUERIES]",
    ) else {
        return Ok(());
    };
    let usage = "usage: ann_compare SHAPES INDEX [QUERIES]";
    let n: usize = args.get(1).ok_or(usage)?.parse()?;
    let source = args.get(2).ok_or(usage)?;
    let queries: usize = match args.get(3) {
        Some(q) => q.parse()?,
        None => 20,
    };
    let src: Vec<ShapeRecord<DIM>> = IndexReader::<DIM>::open(workspace_path(source))?
        .shapes()?
        .iter()
        .map(|s| (*s.record).clone())
        .collect();
    if src.is_empty() {
        return Err("the source index has no shape".into());
    }
    // the grown index, and every part's descriptor with its (shape, part), in the same order
    let dir = match env_path("SCALE_DIR") {
        Some(parent) => tempfile::tempdir_in(parent)?,
        None => tempfile::tempdir()?,
    };
    let mut jitter = ChaCha8Rng::seed_from_u64(2);
    let mut points: Vec<Vec<f32>> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    {
        let mut w = IndexWriter::<DIM>::create_or_open(dir.path())?;
        for start in (0..n).step_by(5000) {
            let batch: Vec<ShapeRecord<DIM>> = (start..(start + 5000).min(n))
                .map(|i| {
                    let r = grown_copy(&src, i as u64, &mut jitter);
                    points.extend(r.components.iter().map(|c| c.descriptor.to_vec()));
                    counts.push(r.components.len());
                    r
                })
                .collect();
            w.add_batch(batch)?;
        }
    }
    let reader =
        IndexReader::<DIM>::open_mapped(dir.path())?.with_search_mode(SearchMode::Approximate);
    let exact = IndexReader::<DIM>::open_mapped(dir.path())?.with_search_mode(SearchMode::Exact);
    // shapes were added in order to a new index: ids increase with the points' order
    let owners: Vec<(ShapeId, usize)> = reader
        .ids()
        .zip(&counts)
        .flat_map(|(id, &m)| (0..m).map(move |c| (id, c)))
        .collect();
    if owners.len() != points.len() {
        return Err("the index's shapes do not follow the order they were added in".into());
    }
    let k = CANDIDATES_PER_COMPONENT;
    eprintln!("{n} shapes, {} parts: building", points.len());

    let before = resident_mb().unwrap_or(0.0);
    let ivf_build = reader.prepare_search().as_secs_f64();
    let ivf_memory = reader.search_bytes() as f64 / 1e6;
    exact.prepare_search();

    // HNSW: 16 links per node (the paper's M), ef_construction 200, as its authors advise for
    // high recall; parallel insertion on every core
    let before_hnsw = resident_mb().unwrap_or(0.0);
    let t = Instant::now();
    let layers = 16.min((points.len() as f64).ln().max(1.0) as usize);
    let hnsw: Hnsw<f32, DistL2> = Hnsw::new(16, points.len(), layers, 200, DistL2 {});
    let with_ids: Vec<(&Vec<f32>, usize)> = points.iter().zip(0..).collect();
    hnsw.parallel_insert(&with_ids);
    let hnsw_build = t.elapsed().as_secs_f64();
    let hnsw_memory = resident_mb().unwrap_or(0.0) - before_hnsw;
    eprintln!("inverted file built in {ivf_build:.1} s, HNSW in {hnsw_build:.1} s");

    // query shapes: indexed shapes' parts moved by up to ±0.01
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let efs = [64usize, 128, 256];
    let mut ivf_times = Vec::new();
    let mut ivf_recall = Vec::new();
    let mut hnsw_times = vec![Vec::new(); efs.len()];
    let mut hnsw_recall = vec![Vec::new(); efs.len()];
    for _ in 0..queries {
        let shape = rng.random_range(0..counts.len());
        let first: usize = counts[..shape].iter().sum();
        let descs: Vec<[f32; DIM]> = (first..first + counts[shape])
            .map(|i| {
                let mut d = [0f32; DIM];
                for (x, v) in d.iter_mut().zip(&points[i]) {
                    *x = v + rng.random_range(-0.01..0.01);
                }
                d
            })
            .collect();
        let want: Vec<Vec<(ShapeId, usize)>> = exact
            .nearest_components_batch(&descs, k)?
            .into_iter()
            .map(|v| v.into_iter().map(|m| (m.shape, m.component)).collect())
            .collect();
        let t = Instant::now();
        let got = reader.nearest_components_batch(&descs, k)?;
        ivf_times.push(t.elapsed().as_secs_f64() * 1e3);
        let r: Vec<f64> = got
            .iter()
            .zip(&want)
            .map(|(g, w)| {
                let g: Vec<(ShapeId, usize)> = g.iter().map(|m| (m.shape, m.component)).collect();
                recall(&g, w)
            })
            .collect();
        ivf_recall.push(r.iter().sum::<f64>() / r.len().max(1) as f64);
        let as_vecs: Vec<Vec<f32>> = descs.iter().map(|d| d.to_vec()).collect();
        for (e, &ef) in efs.iter().enumerate() {
            let t = Instant::now();
            let got = hnsw.parallel_search(&as_vecs, k, ef);
            hnsw_times[e].push(t.elapsed().as_secs_f64() * 1e3);
            let r: Vec<f64> = got
                .iter()
                .zip(&want)
                .map(|(g, w)| {
                    let g: Vec<(ShapeId, usize)> = g.iter().map(|nb| owners[nb.d_id]).collect();
                    recall(&g, w)
                })
                .collect();
            hnsw_recall[e].push(r.iter().sum::<f64>() / r.len().max(1) as f64);
        }
    }
    println!(
        "| search | shapes | parts | build (s) | memory (MB) | query's parts searched (ms) | recall of the {k} nearest |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    println!(
        "| inverted file (keycomp_index) | {n} | {} | {ivf_build:.1} | {ivf_memory:.0} | {:.1} | {:.4} |",
        points.len(),
        median(ivf_times),
        median(ivf_recall)
    );
    for (e, &ef) in efs.iter().enumerate() {
        println!(
            "| HNSW (hnsw_rs, M 16, ef {ef}) | {n} | {} | {hnsw_build:.1} | {hnsw_memory:.0} | {:.1} | {:.4} |",
            points.len(),
            median(hnsw_times[e].clone()),
            median(hnsw_recall[e].clone())
        );
    }
    eprintln!(
        "resident memory before the searches were built: {before:.0} MB; the HNSW column's memory is the growth of resident memory while it was built (its copy of the vectors and its links)"
    );
    Ok(())
}
