//! Index size, open time, search memory and query latency (excluding the query's own
//! detection) as the index grows. Shapes are synthetic records (4–8 components, random
//! descriptors, `keycomp_index::synthetic`) or, given an index of real shapes, copies of its
//! records with every descriptor value moved by up to ±0.01 (so a 200-shape index of about 84
//! parts per shape grows to any size with realistic descriptors); queries are indexed shapes'
//! descriptors and layout, perturbed alike.
//!
//! `cargo bench -p keycomp-retrieval --bench query_scale -- [SIZES] [INDEX] [QUERIES]`
//! (SIZES: comma-separated shape counts, default 1000,10000,100000; INDEX: an index directory to
//! take records from; QUERIES: queries per size, default 20; `SCALE_DIR=DIR` puts the grown
//! indexes in DIR instead of the temporary folder, and `SCALE_KEEP=1` keeps them there).
//! Prints a markdown table, medians over the queries: the time to write the index (5,000 shapes per `add_batch`) and its size; the
//! memory-mapped open (`IndexReader::open_mapped`, median of 5); the search structure's build
//! (by a first reader, which writes the search cache), its reading from the search cache by a
//! second reader (which answers the queries), its update by a reader after 1 % more shapes were
//! added, its memory; the process's resident memory after the queries; the
//! candidate search alone (the searches of every query part); `rank` for the top 10 and `rank`
//! of every candidate (which must agree on the top 10), with the default search (approximate
//! from `keycomp_index::IVF_MIN_COMPONENTS` components); and the exact ranking
//! (`SearchMode::Exact`: a KD-tree, or above `keycomp_index::EXACT_TREE_MAX` components a scan
//! of every descriptor), the searches of all compared queries in one batch
//! (`nearest_components_batch`, then `rank_neighbours`), its time shared among them, and how
//! many queries get the exact ranking's top 10 (`EXACT_QUERIES=N`: the first N queries only).
//! Relative paths, on the command line and in the environment, are taken from the workspace
//! root.
//!
//! With `FRAGMENTS=DIR` in the environment (DIR: the record cache of a scale-free `keycomp
//! bench retrieval` run, `OUT/cache`), a second table times real fragment queries described
//! under two scale hypotheses (the cached query records with more than one description, the
//! first QUERIES by file name): the candidate search of every part of every description, and
//! `rank_hypotheses` for the top 10, as `keycomp query` ranks a fragment (without
//! verification, as in the first table).

use std::time::Instant;

mod common;
use common::{env_path, grown_copy, perturbed_query, resident_mb, view};
use keycomp_describe::DIM;
use keycomp_index::{IndexReader, IndexWriter, SearchMode, synthetic};
use keycomp_retrieval::{
    CANDIDATES_PER_COMPONENT, MatchParams, ShapeView, rank, rank_hypotheses, rank_neighbours,
};
use keycomp_test_support::{bench_args, median, workspace_path};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args(
        "cargo bench -p keycomp-retrieval --bench query_scale -- [SIZES] [INDEX] [QUERIES]",
    ) else {
        return Ok(());
    };
    let sizes: Vec<u64> = args
        .get(1)
        .map_or("1000,10000,100000", String::as_str)
        .split(',')
        .map(|s| s.trim().parse())
        .collect::<Result<_, _>>()?;
    let queries: usize = match args.get(3) {
        Some(q) => q.parse()?,
        None => 20,
    };
    let source: Option<Vec<keycomp_index::ShapeRecord<DIM>>> = match args.get(2) {
        Some(dir) => Some(
            IndexReader::<DIM>::open(workspace_path(dir))?
                .shapes()?
                .iter()
                .map(|s| (*s.record).clone())
                .collect(),
        ),
        None => None,
    };
    // fragment queries: cached records of every scale hypothesis of a query
    let fragments: Vec<Vec<keycomp_index::ShapeRecord<DIM>>> = match env_path("FRAGMENTS") {
        Some(dir) => {
            let mut files: Vec<_> = std::fs::read_dir(dir)?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "json"))
                .collect();
            files.sort();
            files
                .iter()
                .filter_map(|f| std::fs::read(f).ok())
                .filter_map(|b| {
                    serde_json::from_slice::<Vec<keycomp_index::ShapeRecord<DIM>>>(&b).ok()
                })
                .filter(|r| r.len() > 1)
                .take(queries)
                .collect()
        }
        None => Vec::new(),
    };
    let mut fragment_rows = Vec::new();
    let mut jitter = ChaCha8Rng::seed_from_u64(2);
    let mut records = |range: std::ops::Range<u64>| -> Vec<keycomp_index::ShapeRecord<DIM>> {
        match &source {
            None => synthetic::records(7, range),
            Some(src) if !src.is_empty() => {
                range.map(|i| grown_copy(src, i, &mut jitter)).collect()
            }
            Some(_) => Vec::new(),
        }
    };
    println!(
        "| shapes | components | index written (s) | index bytes (GB) | open (ms) | open, read whole (ms) | search build (ms) | search from cache (ms) | search after adding 1 % (ms) | search memory (MB) | resident memory (MB) | candidate search (ms) | query, top 10 (ms) | query, every candidate (ms) | exact: query, top 10 (ms) | top 10 as exact (same order / same set) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for n in sizes {
        let dir = match env_path("SCALE_DIR") {
            Some(parent) => tempfile::tempdir_in(parent)?,
            None => tempfile::tempdir()?,
        };
        let t = Instant::now();
        {
            let mut w = IndexWriter::<DIM>::create_or_open(dir.path())?;
            let mut i = 0;
            while i < n {
                let end = (i + 5000).min(n);
                w.add_batch(records(i..end))?;
                i = end;
            }
        }
        let written = t.elapsed().as_secs_f64();
        eprintln!("{n} shapes: index written in {written:.0} s");
        let mut opens = Vec::new();
        for _ in 0..5 {
            let t = Instant::now();
            let r = IndexReader::<DIM>::open_mapped(dir.path())?;
            opens.push(t.elapsed().as_secs_f64() * 1e3);
            drop(r);
        }
        // reading every segment whole, as before format 5 (and as `IndexReader::open` still
        // does), up to 100,000 shapes (beyond, the records do not fit this machine's memory)
        let whole = if n <= 100_000 {
            let mut t = Vec::new();
            for _ in 0..3 {
                let start = Instant::now();
                drop(IndexReader::<DIM>::open(dir.path())?);
                t.push(start.elapsed().as_secs_f64() * 1e3);
            }
            format!("{:.0}", median(t))
        } else {
            "—".into()
        };
        // the first reader builds the search structure and writes the search cache; a second
        // one, as the next process would, reads the cache and answers the queries (one
        // structure in memory at a time: at a million shapes each is half this machine's memory)
        let first = IndexReader::<DIM>::open_mapped(dir.path())?;
        let build = first.prepare_search().as_secs_f64() * 1e3;
        let mb = first.search_bytes() as f64 / 1e6;
        drop(first);
        eprintln!(
            "{n} shapes: open {:.1} ms, search built in {build:.0} ms",
            median(opens.clone())
        );
        let reader = IndexReader::<DIM>::open_mapped(dir.path())?;
        let cached_ms = reader.prepare_search().as_secs_f64() * 1e3;
        let cached = if reader.search_was_cached() {
            format!("{cached_ms:.0}")
        } else {
            format!("{cached_ms:.0} (built)")
        };
        let exact =
            IndexReader::<DIM>::open_mapped(dir.path())?.with_search_mode(SearchMode::Exact);
        let ids: Vec<keycomp_index::ShapeId> = reader.ids().collect();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let make_query = |rng: &mut ChaCha8Rng| {
            let id = ids[rng.random_range(0..ids.len())];
            perturbed_query(&reader, id, rng).ok().flatten()
        };
        let params = MatchParams::default();
        exact.prepare_search();
        let (mut search, mut times, mut full) = (Vec::new(), Vec::new(), Vec::new());
        // EXACT_QUERIES=N compares the first N queries only with the exact ranking
        let exact_queries: usize = std::env::var("EXACT_QUERIES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(queries)
            .min(queries);
        let ids = |v: &[keycomp_retrieval::Ranked]| v.iter().map(|x| x.id).collect::<Vec<_>>();
        // the queries compared with the exact ranking, and their top 10
        let mut kept = Vec::new();
        for qi in 0..queries {
            let (d, l) = make_query(&mut rng).ok_or("empty index")?;
            let t = Instant::now();
            reader.nearest_components_batch(&d, CANDIDATES_PER_COMPONENT)?;
            search.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            let r = rank(&reader, view(&d, &l), 10, &params)?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
            assert!(!r.is_empty());
            let t = Instant::now();
            let all = rank(&reader, view(&d, &l), usize::MAX, &params)?;
            full.push(t.elapsed().as_secs_f64() * 1e3);
            assert!(
                r.iter()
                    .zip(&all)
                    .all(|(a, b)| a.id == b.id && a.result == b.result)
            );
            eprintln!(
                "{n} shapes: query {qi}: search {:.1} ms, top 10 {:.1} ms",
                search[qi], times[qi]
            );
            if qi < exact_queries {
                kept.push((d, l, ids(&r)));
            }
        }
        if !fragments.is_empty() {
            let (mut search, mut times, mut parts) = (Vec::new(), Vec::new(), Vec::new());
            for hyps in &fragments {
                let descs: Vec<Vec<[f32; DIM]>> = hyps
                    .iter()
                    .map(|r| r.components.iter().map(|c| c.descriptor).collect())
                    .collect();
                let t = Instant::now();
                for d in &descs {
                    reader.nearest_components_batch(d, CANDIDATES_PER_COMPONENT)?;
                }
                search.push(t.elapsed().as_secs_f64() * 1e3);
                let views: Vec<ShapeView> = descs
                    .iter()
                    .zip(hyps)
                    .map(|(d, r)| view(d, &r.layout))
                    .collect();
                let t = Instant::now();
                let r = rank_hypotheses(&reader, &views, 10, &params)?;
                times.push(t.elapsed().as_secs_f64() * 1e3);
                assert!(!r.is_empty());
                parts.push(descs.iter().map(Vec::len).sum::<usize>() as f64);
            }
            fragment_rows.push(format!(
                "| {n} | {} | {:.0} | {:.2} | {:.2} |",
                fragments.len(),
                median(parts),
                median(search),
                median(times)
            ));
        }
        let components = reader.component_count();
        let resident = resident_mb().map_or_else(|| "n/a".into(), |m| format!("{m:.0}"));
        let bytes = reader.stats().bytes as f64 / 1e9;
        // the exact rankings of the kept queries, their searches in one batch (above
        // EXACT_TREE_MAX parts, one scan of the descriptors for all of them), with the
        // approximate search's memory freed first
        drop(reader);
        let t = Instant::now();
        let parts: Vec<[f32; DIM]> = kept.iter().flat_map(|q| q.0.iter().copied()).collect();
        let mut neighbours = exact.nearest_components_batch(&parts, CANDIDATES_PER_COMPONENT)?;
        let (mut same, mut same_set) = (0, 0);
        for (qi, (d, l, approximate)) in kept.iter().enumerate() {
            let rest = neighbours.split_off(d.len());
            let e = rank_neighbours(&exact, view(d, l), &neighbours, 10, &params)?;
            neighbours = rest;
            same += usize::from(ids(&e) == *approximate);
            let (mut a, mut b) = (approximate.clone(), ids(&e));
            a.sort_unstable();
            b.sort_unstable();
            same_set += usize::from(a == b);
            eprintln!(
                "{n} shapes: query {qi}: exact top 10 the same: {}",
                ids(&e) == *approximate
            );
        }
        // per query, the batch's time shared among its queries
        let exact_ms = t.elapsed().as_secs_f64() * 1e3 / kept.len().max(1) as f64;
        // an add of 1 % more shapes: the next process's first search updates the cache
        drop(exact);
        let more = (n / 100).max(1);
        IndexWriter::<DIM>::create_or_open(dir.path())?.add_batch(records(n..n + more))?;
        let after = IndexReader::<DIM>::open_mapped(dir.path())?;
        let after_ms = after.prepare_search().as_secs_f64() * 1e3;
        let updated = match after.search_source() {
            keycomp_index::SearchSource::Built => format!("{after_ms:.0} (built)"),
            _ => format!("{after_ms:.0}"),
        };
        println!(
            "| {n} | {} | {written:.0} | {bytes:.1} | {:.1} | {whole} | {:.0} | {cached} | {updated} | {:.0} | {resident} | {:.2} | {:.2} | {:.2} | {:.0} | {same} / {same_set} of {exact_queries} |",
            components,
            median(opens),
            build,
            mb,
            median(search),
            median(times),
            median(full),
            exact_ms,
        );
        if std::env::var_os("SCALE_KEEP").is_some() {
            eprintln!("{n} shapes: index kept in {}", dir.keep().display());
        }
    }
    if !fragment_rows.is_empty() {
        println!(
            "\n| shapes | fragment queries | parts (both descriptions) | candidate search (ms) | query, top 10 (ms) |"
        );
        println!("|---:|---:|---:|---:|---:|");
        for row in fragment_rows {
            println!("{row}");
        }
    }
    Ok(())
}
