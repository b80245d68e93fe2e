//! The report as markdown: per preset the paper's Table 1 layout with "ours / paper" in each
//! cell, the per-strength table, and the null shapes' detections; then the skipped shapes.

use std::fmt::Write as _;

use keycomp_components::{Grouping, SphereRule};
use keycomp_mser::Method;

use super::config::PresetSpec;
use super::report::{CLUSTER_RADIUS, KEYPOINT_RADIUS, Report};
use crate::paper::row_label;

fn cell(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |x| format!("{x:.2}"))
}

impl Report {
    /// A preset's parameters in words: `R 0.15, T 0.3, N 30, σ 1.5` for key-components (the
    /// diffusion time, prominence, radius and most components for salient peaks), the
    /// weights, times, eigenpairs and stability parameters for the MSER methods.
    pub fn preset_parameters(&self, p: &PresetSpec) -> String {
        match p.method {
            Method::Kc => {
                let sphere = match p.sphere {
                    SphereRule::Enclosing => String::new(),
                    SphereRule::Spread { factor } => format!(", spread sphere ×{factor}"),
                };
                let smoothing = match (
                    self.harris.smoothing_length,
                    self.harris.smoothing_iterations,
                ) {
                    (Some(l), _) => format!(", Harris after smoothing over {l} unit lengths"),
                    (None, 0) => String::new(),
                    (None, n) => format!(", Harris after {n} Taubin pairs"),
                };
                match p.grouping {
                    Grouping::Salient(sp) => format!(
                        "salient peaks: t {}, prominence {}, radius {}, at most {}{smoothing}",
                        sp.time, sp.prominence, sp.radius, sp.max_components
                    ),
                    Grouping::Adaptive => format!(
                        "R {}, T {}, N {}, σ {}{sphere}{smoothing}",
                        p.cluster.r, p.cluster.t, p.cluster.n_min, p.sigma
                    ),
                }
            }
            Method::Mser | Method::MserKc => {
                let m = &self.mser;
                format!(
                    "{} weights, t {}·area, {} eigenpairs, Δ {}, area {}–{}, max variation {}, \
                     min diversity {}; HKS keypoints at t {}·area",
                    m.weighting,
                    m.time,
                    m.eigenpairs,
                    m.stable.delta,
                    m.stable.min_area,
                    m.stable.max_area,
                    m.stable.max_variation,
                    m.stable.min_diversity,
                    m.keypoint_time
                )
            }
        }
    }

    /// The tables as markdown: per preset, the paper's Table 1 layout with "ours / paper" in
    /// each cell, repeatability at overlap 0.8, and the null shapes' detections; then the
    /// skipped shapes.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        // writing into a String cannot fail
        let _ = writeln!(s, "Keypoint budget: {}.", self.budget);
        let _ = writeln!(
            s,
            "Null shapes: {}; {} shapes evaluated, {} skipped; transformation seed {}.\n",
            self.nulls
                .iter()
                .map(|n| n.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            self.shapes.len(),
            self.skipped.len(),
            self.seed
        );
        for (p, pr) in self.presets.iter().enumerate() {
            let source = pr.paper.map_or("", |t| t.source);
            let _ = writeln!(
                s,
                "### {} ({}): average overlap{}\n",
                pr.preset.name,
                self.preset_parameters(&pr.preset),
                if pr.paper.is_some() {
                    format!(", ours / paper ({source})")
                } else {
                    String::new()
                }
            );
            let _ = writeln!(
                s,
                "| Transform. | 1 | ≤ 2 | ≤ 3 | ≤ 4 | ≤ 5 | components (≤ 5) | repeatability at 0.8 (≤ 5) |"
            );
            let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|");
            for (i, row) in pr.mean_overlap.rows.iter().enumerate() {
                let paper = pr.paper.and_then(|t| t.row(&row.kind));
                let cells: Vec<String> = row
                    .values
                    .iter()
                    .enumerate()
                    .map(|(c, v)| match paper {
                        Some(pv) => format!("{} / {:.2}", cell(*v), pv[c]),
                        None => cell(*v),
                    })
                    .collect();
                let count = pr
                    .component_counts
                    .get(i)
                    .and_then(|(_, v)| v.last())
                    .copied();
                let rep = pr
                    .repeatability_at_0_8
                    .rows
                    .get(i)
                    .and_then(|r| r.values.last().copied().flatten());
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} |",
                    row_label(&row.kind),
                    cells.join(" | "),
                    count.unwrap_or(0),
                    cell(rep)
                );
            }
            let avg: Vec<String> = pr
                .mean_overlap
                .average
                .iter()
                .enumerate()
                .map(|(c, v)| match pr.paper {
                    Some(t) => format!("{} / {:.2}", cell(*v), t.average[c]),
                    None => cell(*v),
                })
                .collect();
            let rep_avg = pr.repeatability_at_0_8.average.last().copied().flatten();
            let _ = writeln!(s, "| Average | {} | | {} |", avg.join(" | "), cell(rep_avg));
            let _ = writeln!(
                s,
                "\n{}, ours per exact strength (= s, not pooled; components per strength):\n",
                pr.preset.name
            );
            let _ = writeln!(s, "| Transform. | = 1 | = 2 | = 3 | = 4 | = 5 |");
            let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
            let table = &pr.mean_overlap_per_strength;
            for (i, row) in table.rows.iter().enumerate() {
                let counts = pr.component_counts.get(i).map(|(_, v)| v.as_slice());
                let cells: Vec<String> = row
                    .values
                    .iter()
                    .enumerate()
                    .map(|(c, v)| {
                        // counts are cumulative: this strength's is the difference
                        let n = counts.map_or(0, |k| {
                            let upto = |i: usize| k.get(i).copied().unwrap_or(0);
                            upto(c).saturating_sub(if c > 0 { upto(c - 1) } else { 0 })
                        });
                        format!("{} ({n})", cell(*v))
                    })
                    .collect();
                let _ = writeln!(s, "| {} | {} |", row_label(&row.kind), cells.join(" | "));
            }
            let avg: Vec<String> = table.average.iter().map(|v| cell(*v)).collect();
            let _ = writeln!(s, "| Average | {} |", avg.join(" | "));
            if pr
                .stages
                .iter()
                .any(|r| r.keypoints.is_some() || r.clusters.is_some())
            {
                let _ = writeln!(
                    s,
                    "\n{}, stage by stage (all strengths pooled): the share of keypoints within \
                     {KEYPOINT_RADIUS} unit lengths of a null keypoint, the mean best overlap of \
                     the clusters (the area within {CLUSTER_RADIUS} unit lengths of their \
                     keypoints) and of the components:\n",
                    pr.preset.name
                );
                let _ = writeln!(s, "| Transform. | keypoints | clusters | components |");
                let _ = writeln!(s, "|---|---:|---:|---:|");
                for r in &pr.stages {
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} |",
                        row_label(&r.kind),
                        cell(r.keypoints),
                        cell(r.clusters),
                        cell(r.components)
                    );
                }
            }
            let _ = writeln!(s);
            // the null shapes' own detections explain empty or weak rows
            let nulls: Vec<String> = self
                .shapes
                .iter()
                .filter(|sh| sh.kind == "null")
                .map(|sh| format!("{} {}", sh.null, sh.presets[p].components))
                .collect();
            let _ = writeln!(s, "Components on the null shapes: {}.\n", nulls.join(", "));
        }
        if !self.skipped.is_empty() {
            let _ = writeln!(s, "Skipped:");
            for k in &self.skipped {
                let _ = writeln!(s, "- {} {} {}: {}", k.null, k.kind, k.strength, k.reason);
            }
        }
        s
    }
}
