//! A run's outputs: `results.json`, a precision-recall plot per query set (`pr-<set>.svg`),
//! and the tables printed on stdout.

use std::fmt::Write as _;

use anyhow::{Context, Result};
use keycomp_bench::retrieval::pr_svg;
use keycomp_bench::svg::Curve;

use super::args::{Args, stem};
use super::results::{QueryResult, Results};
use crate::output;

/// Writes `OUT/results.json` and `OUT/pr-<set>.svg`; `methods` are the baselines' (label,
/// key) pairs.
pub(super) fn write(
    results: &Results,
    args: &Args,
    methods: &[(&str, &'static str)],
) -> Result<()> {
    let json = serde_json::to_vec_pretty(&results).context("cannot serialise the results")?;
    output::write_bytes(&args.out.join("results.json"), &json)?;
    for set in &results.query_sets {
        let mut curves = vec![Curve {
            label: "key-components".into(),
            values: set.key_components.summary.mean.pr.clone(),
        }];
        for &(label, key) in methods {
            curves.push(Curve {
                label: label.into(),
                values: set.baselines[key].summary.mean.pr.clone(),
            });
        }
        curves.push(Curve {
            label: "random".into(),
            values: set.random.summary.mean.pr.clone(),
        });
        let title = format!(
            "{} queries ({}) on {}",
            set.name,
            set.queries,
            stem(&args.collection)
        );
        output::write_bytes(
            &args.out.join(format!("pr-{}.svg", set.name)),
            pr_svg(&title, &curves).as_bytes(),
        )?;
    }
    Ok(())
}

/// Wall-clock times of a run, in seconds.
pub(super) struct Times {
    /// Analysing the collection (records, D2 histograms, FPFH points).
    pub(super) detect: f64,
    /// Fitting the FPFH baselines (features of the collection, codebooks, idf).
    pub(super) fit: f64,
    /// The whole run.
    pub(super) total: f64,
}

/// The tables printed on stdout; `methods` are the baselines' (label, key) pairs, in order.
pub(super) fn report_text(
    r: &Results,
    args: &Args,
    preset: &str,
    hits: usize,
    methods: &[(&str, &'static str)],
    times: &Times,
) -> Result<String> {
    let mut s = String::new();
    writeln!(
        s,
        "{}: {} shapes, {} classes ({}); {:.2} key-components per shape, {} shapes without any",
        r.collection,
        r.shapes,
        r.classes.len(),
        r.classes
            .iter()
            .map(|(c, k)| format!("{c} {k}"))
            .collect::<Vec<_>>()
            .join(", "),
        r.components_per_shape,
        r.shapes_without_components.len()
    )?;
    writeln!(
        s,
        "preset {}, seed {}, fragments keep {:.0}-{:.0} % of the area\n",
        preset,
        r.seed,
        100.0 * r.fraction_range.0,
        100.0 * r.fraction_range.1
    )?;
    writeln!(
        s,
        "| queries | n | area | method | NN | FT | ST | E | DCG | mAP | source rank | source 1st | source top 3 | source ahead | no result |"
    )?;
    writeln!(
        s,
        "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for set in &r.query_sets {
        let mut rows = vec![("key-components", &set.key_components)];
        rows.extend(
            methods
                .iter()
                .map(|&(label, key)| (label, &set.baselines[key])),
        );
        rows.push(("random", &set.random));
        for (label, m) in rows {
            let x = &m.summary.mean;
            writeln!(
                s,
                "| {} | {} | {} | {label} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {} | {} | {} |",
                set.name,
                m.summary.queries,
                set.mean_fraction
                    .map_or("100 %".to_string(), |f| format!("{:.0} %", 100.0 * f)),
                x.nn,
                x.ft,
                x.st,
                x.e,
                x.dcg,
                x.ap,
                m.mean_source_rank
                    .map_or("-".to_string(), |v| format!("{v:.1}")),
                m.source_first.map_or("-".to_string(), |v| format!("{v}")),
                m.source_top3.map_or("-".to_string(), |v| format!("{v}")),
                m.source_ahead.map_or("-".to_string(), |v| format!("{v}")),
                if label == "random" {
                    "-".to_string()
                } else {
                    m.empty.to_string()
                }
            )?;
        }
    }
    // candidate recall: the partial queries whose source reached verification
    let recall: Vec<String> = r
        .query_sets
        .iter()
        .filter_map(|set| {
            set.key_components
                .source_verified
                .map(|v| format!("{} {v} of {}", set.name, set.queries))
        })
        .collect();
    if !recall.is_empty() {
        writeln!(
            s,
            "\nsource verified (key-components: the source reached geometric verification's shortlist): {}",
            recall.join(", ")
        )?;
    }
    // the queries key-components answer
    writeln!(
        s,
        "\nqueries for which key-components return at least one shape (every method on the same \
         queries):\n"
    )?;
    writeln!(
        s,
        "| queries | answered | method | NN | FT | mAP | source rank |"
    )?;
    writeln!(s, "|---|---:|---|---:|---:|---:|---:|")?;
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:.3}")
        } else {
            "-".to_string()
        }
    };
    let rank = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}"));
    for set in &r.query_sets {
        let k = &set.answered.key_components;
        let mut rows = vec![("key-components", k)];
        rows.extend(
            methods
                .iter()
                .map(|&(label, key)| (label, &set.answered.baselines[key])),
        );
        for (label, m) in rows {
            writeln!(
                s,
                "| {} | {} of {} | {label} | {} | {} | {} | {} |",
                set.name,
                k.summary.queries + k.summary.undefined,
                set.queries,
                num(m.summary.mean.nn),
                num(m.summary.mean.ft),
                num(m.summary.mean.ap),
                rank(m.mean_source_rank),
            )?;
        }
    }
    if !r.partial_repeatability.is_empty() {
        writeln!(
            s,
            "\npartial repeatability (source parts with at least half their area in the fragment; mean best area overlap with the fragment's own parts):\n"
        )?;
        writeln!(
            s,
            "| kind | kept area | fragments | key-components | KC overlap | patches | patch overlap |\n|---|---|---:|---:|---:|---:|---:|"
        )?;
        for row in &r.partial_repeatability {
            writeln!(
                s,
                "| {} | {:.0}-{:.0} % | {} | {} | {:.3} | {} | {:.3} |",
                row.kind,
                row.area.0 * 100.0,
                row.area.1 * 100.0,
                row.fragments,
                row.kc_parts,
                row.kc_overlap,
                row.patch_parts,
                row.patch_overlap
            )?;
        }
    }
    // per class, whole-shape queries
    if let Some(whole) = r.query_sets.first() {
        writeln!(
            s,
            "\nwhole-shape queries per class (mean; components = key-components per shape):\n"
        )?;
        let columns: Vec<(&str, Option<&str>)> = std::iter::once(("KC", None))
            .chain(methods.iter().map(|&(label, key)| (label, Some(key))))
            .collect();
        let mut header = "| class | shapes | components |".to_string();
        let mut rule = "|---|---:|---:|".to_string();
        for (label, _) in &columns {
            write!(header, " {label} NN | {label} FT | {label} mAP |")?;
            rule.push_str("---:|---:|---:|");
        }
        writeln!(s, "{header}\n{rule}")?;
        for class in r.classes.keys() {
            let rs: Vec<&QueryResult> =
                whole.results.iter().filter(|q| &q.class == class).collect();
            let mean = |f: &dyn Fn(&QueryResult) -> Option<f64>| {
                let v: Vec<f64> = rs.iter().filter_map(|q| f(q)).collect();
                if v.is_empty() {
                    "-".to_string()
                } else {
                    format!("{:.3}", v.iter().sum::<f64>() / v.len() as f64)
                }
            };
            write!(
                s,
                "| {class} | {} | {} |",
                rs.len(),
                mean(&|q| Some(q.components as f64)).replace(".000", ""),
            )?;
            for &(_, key) in &columns {
                write!(
                    s,
                    " {} | {} | {} |",
                    mean(&|q| q.method(key).nn),
                    mean(&|q| q.method(key).ft),
                    mean(&|q| q.method(key).ap)
                )?;
            }
            writeln!(s)?;
        }
    }
    let undefined: usize = r
        .query_sets
        .iter()
        .map(|q| q.key_components.summary.undefined)
        .sum();
    if undefined > 0 {
        writeln!(
            s,
            "\n{undefined} queries left out of the means: their class has no other shape"
        )?;
    }
    writeln!(
        s,
        "\nPSB measures (micro-averaged over queries; macro-averages in results.json); \
         'random': a seeded shuffle, the chance level; 'no result': queries for which the \
         method returned no shape (ranked at random).\n\
         time: {:.1} s ({:.1} s analysing the collection, {hits} of {} records from the cache; \
         {:.1} s fitting the FPFH codebooks); wrote {}",
        times.total,
        times.detect,
        r.shapes,
        times.fit,
        args.out.join("results.json").display()
    )?;
    Ok(s)
}
