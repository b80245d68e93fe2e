//! `keycomp bench retrieval`: retrieval quality of a labelled collection, key-components against
//! two baselines, the D2 shape distribution and an FPFH bag of words, on whole-shape and partial
//! queries.
//!
//! **Key-components** go through the product path: every collection file is analysed by
//! [`keycomp::record_of`], the function `keycomp index add` uses, with the same
//! detection options ([`crate::args::DetectArgs::retrieval_params`], the same defaults, including the
//! scaling of N for small meshes), the records are written to a fresh on-disk index in
//! `OUT/index` (opened by [`crate::progress::open_writer`], as `index add` does), and each query is ranked by `keycomp_retrieval::rank` over that
//! index, as `keycomp query` does. A partial query is written to `OUT/fragments` as an OFF file
//! and analysed as `keycomp query` analyses a file given to it ([`keycomp::records_as`] with
//! [`keycomp::Role::Query`]: scale-free, a fragment is described under two scale hypotheses
//! and ranked by `keycomp_retrieval::rank_hypotheses`); so is a whole shape with a boundary
//! queried whole. Shapes `rank` does not return (no part among the nearest
//! neighbours of a query part) follow in a seeded random order ([`keycomp_bench::retrieval::complete_ranking`]).
//!
//! **Baselines** are a descriptor per mesh and a distance between descriptors ([`baselines::Baseline`]),
//! computed on the same queries (a fragment's descriptors from the fragment mesh that is written
//! and indexed for key-components):
//!
//! * **D2** (Osada et al. 2002, [`keycomp_bench::retrieval::d2`]): L1 distance between
//!   histograms.
//! * **FPFH BoW** and **FPFH BoW units** (Rusu et al. 2009,
//!   [`keycomp_bench::retrieval::fpfh`]): FPFHs of 3,000 points sampled on each mesh, a
//!   256-word k-means codebook fitted on the collection's features, tf-idf weighted histograms
//!   of words, cosine distance. The neighbourhood radius is 0.075·√A with A the mesh's own area
//!   ("FPFH BoW", scale-free) or the median area of the collection's shapes ("FPFH BoW units":
//!   one radius in file units for every shape and fragment, so a fragment keeps its source's
//!   scale). The collection's points are sampled once and described at both radii; each mode
//!   has its own codebook and idf, fitted before any fragment is cut.
//!
//! **Cache.** Records are cached in `OUT/cache` (or `--cache`) as JSON, keyed by a hash of the
//! file's content, the detection parameters, the role (shape or query) and the running
//! executable's bytes ([`keycomp_bench::cache`], the benchmarks' one cache rule): a rebuilt
//! binary (whose detection may have changed) never reuses an old entry, and a re-run of the
//! same binary skips detection. Entries are written atomically; an unreadable entry is
//! recomputed.
//!
//! **External queries** (`--queries DIR --truth CSV`): files from elsewhere (real range scans,
//! point clouds, meshes at another resolution), each named in the CSV with its source shape in
//! the collection, are ranked as `keycomp query` ranks them and by every baseline (which
//! describe the file's triangles, or a point cloud's canonical surface), and measured as the
//! query set `external` with the same tables as the cut fragments.
//!
//! The measures are documented in [`keycomp_bench::retrieval::metrics`].

mod answer;
mod args;
mod baselines;
mod cache;
mod collection;
mod external;
mod partial;
mod repeatability;
mod report;
mod results;
mod setup;
mod whole;

use std::collections::BTreeMap;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};

use crate::output;
use answer::Setting;
pub use args::{Args, EXAMPLES};
use cache::RecordCache;
use collection::Collection;
use report::{Times, report_text};
use results::{Results, query_set};
use setup::Setup;

pub fn run(args: Args) -> Result<ExitCode> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start the thread pool")?;
    pool.install(|| run_in_pool(args))
}

/// The run: the collection analysed and indexed, the baselines fitted, then the query sets
/// (whole shapes, fragments of each kind, external files) measured, written and printed.
fn run_in_pool(args: Args) -> Result<ExitCode> {
    let t0 = Instant::now();
    let setup = Setup::new(&args)?;
    let n = setup.files.len();
    output::create_output_folder(&args.out)?;
    let cache = RecordCache::new(
        args.cache.clone().unwrap_or_else(|| args.out.join("cache")),
        &setup.params,
    );
    let Collection {
        records,
        hists,
        points,
        hits,
    } = collection::analyse(
        &setup.files,
        &setup.params,
        &cache,
        !args.no_baselines,
        &setup.d2_params,
        &setup.fpfh_params,
    )?;
    let detect_s = t0.elapsed().as_secs_f64();
    let t_fit = Instant::now();
    let (baselines, fpfh_scales) = baselines::fit(
        args.no_baselines,
        &setup.files,
        hists,
        points,
        setup.d2_params,
        &setup.fpfh_params,
    )?;
    let fit_s = t_fit.elapsed().as_secs_f64();
    let (reader, index_of) =
        collection::fresh_index(&args.out, &setup.params, &records, &setup.files)?;
    let setting = Setting {
        args: &args,
        cache: &cache,
        params: &setup.params,
        reader: &reader,
        index_of: &index_of,
        match_params: &setup.match_params,
        baselines: &baselines,
        classes: &setup.classes,
        names: &setup.names,
        files: &setup.files,
    };
    let methods: Vec<(&str, &str)> = baselines.iter().map(|b| (b.label, b.key)).collect();
    let mut sets = vec![query_set(
        "whole",
        whole::queries(&setting, &records)?,
        &methods,
    )];
    let (by_kind, repeatability) = partial::queries(&setting, &setup.kinds)?;
    for (kind, results) in by_kind {
        sets.push(query_set(kind.name(), results, &methods));
    }
    if let Some(truth) = &setup.external {
        sets.push(query_set(
            "external",
            external::queries(&setting, truth)?,
            &methods,
        ));
    }
    let mut class_counts: BTreeMap<String, usize> = BTreeMap::new();
    for c in &setup.classes {
        *class_counts.entry(c.clone()).or_default() += 1;
    }
    let results = Results {
        collection: args.collection.display().to_string(),
        shapes: n,
        classes: class_counts,
        seed: args.seed,
        fraction_range: args.area,
        detect_params: setup.params.detect,
        describe_params: setup.params.describe,
        match_params: setup.match_params,
        verify_weight: args.verify_weight,
        d2_params: setup.d2_params,
        fpfh_params: setup.fpfh_params,
        fpfh_scales: fpfh_scales.iter().map(|&(_, k, s)| (k, s)).collect(),
        shapes_without_components: records
            .iter()
            .zip(&setup.names)
            .filter(|(r, _)| r.components.is_empty())
            .map(|(_, s)| s.clone())
            .collect(),
        components_per_shape: records.iter().map(|r| r.components.len()).sum::<usize>() as f64
            / n as f64,
        query_sets: sets,
        partial_repeatability: repeatability::repeatability_rows(&repeatability, args.area),
    };
    report::write(&results, &args, &methods)?;
    let times = Times {
        detect: detect_s,
        fit: fit_s,
        total: t0.elapsed().as_secs_f64(),
    };
    let text = report_text(
        &results,
        &args,
        &setup.detect.retrieval_preset().to_string(),
        hits,
        &methods,
        &times,
    )?;
    output::print_text(&text)?;
    Ok(ExitCode::SUCCESS)
}
