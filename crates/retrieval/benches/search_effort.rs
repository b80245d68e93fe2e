//! Where the approximate search loses the exact ranking's top 10, and what each search effort
//! costs: for several [`SearchEffort`]s (fine cells scanned, re-ranked candidates), the search
//! of a query's parts, that search and the ranking of the top 10 (`rank`'s two steps), the
//! recall of each part's `CANDIDATES_PER_COMPONENT` exact neighbours, and how many queries get
//! the exact ranking's top 10: with the neighbours as the inverted file gives them, and with
//! the same neighbours at their true distances (which separates the neighbours missed from
//! the rounding of the distances that vote for candidates).
//!
//! The index is grown as `query_scale` grows it (copies of real records, every descriptor
//! value moved by up to ±0.01), from the first SOURCES shapes of the source index only: with
//! S sources and N shapes, each source has N / S near-identical copies, so a small index has
//! the density of near duplicates of a large one (200 sources at 1,000,000 shapes is 5,000
//! copies each; so are 20 sources at 100,000). Queries are indexed shapes' parts moved alike.
//!
//! `cargo bench -p keycomp-retrieval --bench search_effort -- SHAPES INDEX [QUERIES]
//! [SOURCES] [EFFORTS]` (EFFORTS: comma-separated `COARSExFINExRERANKxSETTLE`: coarse cells
//! probed, fine cells examined, re-ranked candidates per neighbour, and whether the `k`-th
//! place is settled by descriptors (1) or not (0), with no limit by share of the cells
//! (`SearchEffort::fine_share` 1); default `4x160x2x1,6x160x2x1`;
//! `SCALE_DIR=DIR` puts the grown index in DIR). With `GROWN=DIR`, the index at DIR (e.g. one
//! grown by `query_scale`, kept) is searched instead of one grown here, SHAPES and SOURCES
//! unused, and the true-distance column is left out (it reads every neighbour's record). With
//! `DROP_CACHES=1` (Linux, as root), the system's page cache is dropped before each effort's
//! queries, so that the parts of the index they read come from the disk, as for a process's
//! first queries on an index larger than memory. With `TRUTH=FILE`, the exact results are read
//! from FILE when it holds them for the same queries (the same index: the queries are its
//! records moved), else computed and written there (they take about as long as
//! `query_scale`'s exact search). Prints a markdown table; medians
//! over the queries, and the bytes read from the disk per query (mean, Linux; the reads the
//! page cache serves are not counted).
//! Relative paths, on the command line and in the environment, are taken from the workspace
//! root.

use std::time::Instant;

mod common;
use common::{disk_read_bytes, env_path, grown_copy, perturbed_query, view};
use keycomp_describe::DIM;
use keycomp_index::{
    ComponentMatch, IndexReader, IndexWriter, SearchEffort, SearchMode, ShapeId, ShapeRecord,
};
use keycomp_retrieval::{CANDIDATES_PER_COMPONENT, MatchParams, rank_neighbours};
use keycomp_test_support::{bench_args, median, workspace_path};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args(
        "cargo bench -p keycomp-retrieval --bench search_effort -- SHAPES INDEX [QUERIES] [SOURCES] [EFFORTS]",
    ) else {
        return Ok(());
    };
    let usage = "usage: search_effort SHAPES INDEX [QUERIES] [SOURCES] [EFFORTS]";
    let n: u64 = args.get(1).ok_or(usage)?.parse()?;
    let source = args.get(2).ok_or(usage)?;
    let queries: usize = args.get(3).map_or(Ok(20), |q| q.parse())?;
    let mut src: Vec<ShapeRecord<DIM>> = IndexReader::<DIM>::open(workspace_path(source))?
        .shapes()?
        .iter()
        .map(|s| (*s.record).clone())
        .collect();
    if let Some(s) = args.get(4) {
        src.truncate(s.parse()?);
    }
    if src.is_empty() {
        return Err("no source shape".into());
    }
    let efforts: Vec<SearchEffort> = args
        .get(5)
        .map_or("4x160x2x1,6x160x2x1", String::as_str)
        .split(',')
        .map(|e| {
            let v: Vec<usize> = e
                .split('x')
                .map(|v| v.trim().parse())
                .collect::<Result<_, _>>()?;
            match v[..] {
                [coarse_probes, fine_probes, rerank, settle @ (0 | 1)] => Ok(SearchEffort {
                    coarse_probes,
                    fine_probes,
                    // the cells asked for, whatever the index's size
                    fine_share: 1.0,
                    rerank,
                    settle: settle == 1,
                }),
                _ => Err::<_, Box<dyn std::error::Error>>(
                    "an effort is COARSExFINExRERANKxSETTLE (SETTLE: 0 or 1)".into(),
                ),
            }
        })
        .collect::<Result<_, _>>()?;

    let grown = env_path("GROWN");
    // the index searched, and the folder grown here (removed at the end)
    let (dir, made) = match &grown {
        Some(g) => (g.clone(), None),
        None => {
            let t = match env_path("SCALE_DIR") {
                Some(parent) => tempfile::tempdir_in(parent)?,
                None => tempfile::tempdir()?,
            };
            (t.path().to_path_buf(), Some(t))
        }
    };
    if made.is_some() {
        let mut jitter = ChaCha8Rng::seed_from_u64(2);
        let mut w = IndexWriter::<DIM>::create_or_open(&dir)?;
        let mut i = 0;
        while i < n {
            let end = (i + 5000).min(n);
            w.add_batch((i..end).map(|i| grown_copy(&src, i, &mut jitter)).collect())?;
            i = end;
        }
    }
    let open = |effort: SearchEffort| -> Result<IndexReader<DIM>, keycomp_index::IndexError> {
        Ok(IndexReader::<DIM>::open_mapped(&dir)?
            .with_search_mode(SearchMode::Approximate)
            .with_search_effort(effort))
    };
    let build = open(SearchEffort::default())?
        .prepare_search()
        .as_secs_f64();
    eprintln!("{}: inverted file ready in {build:.0} s", dir.display());

    // queries: indexed shapes' parts moved by up to ±0.01, as in query_scale
    let exact = IndexReader::<DIM>::open_mapped(&dir)?.with_search_mode(SearchMode::Exact);
    let ids: Vec<ShapeId> = exact.ids().collect();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut asked: Vec<(Vec<[f32; DIM]>, Vec<f32>)> = Vec::new();
    for _ in 0..queries {
        let id = ids[rng.random_range(0..ids.len())];
        asked.push(perturbed_query(&exact, id, &mut rng)?.ok_or("a listed shape has no record")?);
    }
    let params = MatchParams::default();
    let top = |v: &[keycomp_retrieval::Ranked]| v.iter().map(|r| r.id).collect::<Vec<_>>();
    // the exact neighbours of every query part in one batch, and the exact rankings (read
    // from TRUTH when it was written for these queries)
    let saved = env_path("TRUTH");
    let key = {
        let bytes: Vec<u8> = asked
            .iter()
            .flat_map(|q| q.0.iter().flatten().chain(&q.1))
            .flat_map(|v| v.to_le_bytes())
            .collect();
        keycomp_index::ContentHash::of_bytes(&bytes).to_string()
    };
    let mut truth = match saved.as_deref().filter(|p| p.exists()) {
        Some(p) => read_truth(p, &key)?,
        None => Vec::new(),
    };
    if truth.is_empty() {
        let parts: Vec<[f32; DIM]> = asked.iter().flat_map(|q| q.0.iter().copied()).collect();
        let mut all = exact.nearest_components_batch(&parts, CANDIDATES_PER_COMPONENT)?;
        for (d, l) in &asked {
            let rest = all.split_off(d.len());
            let ranked = rank_neighbours(&exact, view(d, l), &all, 11, &params)?;
            // the gap between the 10th and the 11th score: how firm the exact top 10 is
            let gap = match (ranked.get(9), ranked.get(10)) {
                (Some(a), Some(b)) => a.result.score - b.result.score,
                _ => f64::INFINITY,
            };
            truth.push((top(&ranked[..ranked.len().min(10)]), all, gap));
            all = rest;
        }
        if let Some(p) = &saved {
            write_truth(p, &key, &truth)?;
        }
    }
    let gaps: Vec<f64> = truth.iter().map(|t| t.2).collect();
    eprintln!(
        "exact rankings done; gap between the 10th and 11th score: median {:.2e}, smallest {:.2e}",
        median(gaps.clone()),
        gaps.iter().copied().fold(f64::INFINITY, f64::min)
    );

    println!(
        "| coarse cells probed | fine cells examined | re-ranked (× k) | k-th place settled by descriptors | query's parts searched (ms) | the search and the top 10 ranked (ms) | disk read per query (MB) | recall of the {CANDIDATES_PER_COMPONENT} nearest | top 10 as exact (same order / same set) | the same neighbours at true distances: top 10 as exact |"
    );
    println!("|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|");
    for effort in efforts {
        let reader = open(effort)?;
        reader.prepare_search();
        if std::env::var_os("DROP_CACHES").is_some_and(|v| v == "1") {
            std::fs::write("/proc/sys/vm/drop_caches", "3")?;
        }
        let (mut times, mut whole, mut recalls) = (Vec::new(), Vec::new(), Vec::new());
        let (mut same, mut same_set, mut same_true) = (0, 0, 0);
        // bytes read from the disk by the queries' searches and rankings; None where unknown
        let mut read = Some(0u64);
        for ((d, l), (want, exact_nb, _)) in asked.iter().zip(&truth) {
            let read_before = disk_read_bytes();
            let t = Instant::now();
            let got = reader.nearest_components_batch(d, CANDIDATES_PER_COMPONENT)?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
            let key = |m: &ComponentMatch| (m.shape, m.component);
            let (mut found, mut total) = (0usize, 0usize);
            for (g, w) in got.iter().zip(exact_nb) {
                let g: Vec<_> = g.iter().map(key).collect();
                found += w.iter().filter(|m| g.contains(&key(m))).count();
                total += w.len();
            }
            recalls.push(found as f64 / total.max(1) as f64);
            let t = Instant::now();
            let r = top(&rank_neighbours(&reader, view(d, l), &got, 10, &params)?);
            // the search and the ranking: what `rank` for the top 10 costs
            whole.push(times.last().copied().unwrap_or(0.0) + t.elapsed().as_secs_f64() * 1e3);
            // what the query read (the true-distance check below reads more)
            read = match (read, read_before, disk_read_bytes()) {
                (Some(r), Some(before), Some(now)) => Some(r + now.saturating_sub(before)),
                _ => None,
            };
            same += usize::from(r == *want);
            let (mut a, mut b) = (r.clone(), want.clone());
            a.sort_unstable();
            b.sort_unstable();
            same_set += usize::from(a == b);
            if grown.is_some() {
                continue;
            }
            // the same neighbours, their distances from the descriptors
            let mut at_true = got.clone();
            for (nb, q) in at_true.iter_mut().zip(d) {
                for m in nb.iter_mut() {
                    let rec = exact.get(m.shape)?.ok_or("a neighbour has no record")?;
                    m.distance_sq =
                        keycomp_index::squared_distance(q, &rec.components[m.component].descriptor);
                }
                nb.sort_by(|a, b| {
                    a.distance_sq
                        .total_cmp(&b.distance_sq)
                        .then((a.shape, a.component).cmp(&(b.shape, b.component)))
                });
            }
            let r = top(&rank_neighbours(&exact, view(d, l), &at_true, 10, &params)?);
            same_true += usize::from(r == *want);
        }
        let at_true = if grown.is_some() {
            "—".to_string()
        } else {
            format!("{same_true} of {queries}")
        };
        println!(
            "| {} | {} | {} | {} | {:.1} | {:.1} | {} | {:.4} | {same} / {same_set} of {queries} | {at_true} |",
            effort.coarse_probes,
            effort.fine_probes,
            effort.rerank,
            if effort.settle { "yes" } else { "no" },
            median(times),
            median(whole),
            read.map_or("—".to_string(), |r| format!(
                "{:.2}",
                r as f64 / 1e6 / queries.max(1) as f64
            )),
            recalls.iter().sum::<f64>() / recalls.len().max(1) as f64,
        );
    }
    Ok(())
}

/// A query's exact top 10, its parts' exact neighbours, and the gap between its 10th and 11th
/// scores.
type Truth = (Vec<ShapeId>, Vec<Vec<ComponentMatch>>, f64);

/// Writes the exact results of the queries whose content hash is `key` to `path` (JSON).
fn write_truth(
    path: &std::path::Path,
    key: &str,
    truth: &[Truth],
) -> Result<(), Box<dyn std::error::Error>> {
    let rows: Vec<serde_json::Value> = truth
        .iter()
        .map(|(top, nb, gap)| {
            let nb: Vec<Vec<(u64, usize, f32)>> = nb
                .iter()
                .map(|n| {
                    n.iter()
                        .map(|m| (m.shape.0, m.component, m.distance_sq))
                        .collect()
                })
                .collect();
            let top: Vec<u64> = top.iter().map(|t| t.0).collect();
            serde_json::json!({ "top": top, "neighbours": nb, "gap": gap.min(f64::MAX) })
        })
        .collect();
    let v = serde_json::json!({ "queries": key, "truth": rows });
    std::fs::write(path, serde_json::to_vec(&v)?)?;
    Ok(())
}

/// The exact results [`write_truth`] wrote to `path`, or none when they were written for
/// other queries than those whose content hash is `key`.
fn read_truth(path: &std::path::Path, key: &str) -> Result<Vec<Truth>, Box<dyn std::error::Error>> {
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(path)?)?;
    if v["queries"] != key {
        eprintln!("{}: written for other queries", path.display());
        return Ok(Vec::new());
    }
    let rows = v["truth"].as_array().ok_or("no truth")?;
    let mut out = Vec::new();
    for r in rows {
        let top: Vec<u64> = serde_json::from_value(r["top"].clone())?;
        let nb: Vec<Vec<(u64, usize, f32)>> = serde_json::from_value(r["neighbours"].clone())?;
        let nb = nb
            .into_iter()
            .map(|n| {
                n.into_iter()
                    .map(|(shape, component, distance_sq)| ComponentMatch {
                        shape: ShapeId(shape),
                        component,
                        distance_sq,
                    })
                    .collect()
            })
            .collect();
        out.push((
            top.into_iter().map(ShapeId).collect(),
            nb,
            r["gap"].as_f64().ok_or("no gap")?,
        ));
    }
    Ok(out)
}
