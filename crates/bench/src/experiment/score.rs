//! Scoring: a preset's best overlaps pooled into the paper's tables (mean overlap per
//! transformation and cumulative strength, the same per exact strength, repeatability at
//! overlap 0.8, component counts) and the repeatability-vs-overlap curves (Figs. 7–9).

use crate::evaluate::{
    CumulativeTable, Record, TableRow, average_row, mean_overlap_table, repeatability_curve,
    repeatability_table,
};
use crate::paper::{paper_table, row_label, row_order};
use crate::transform::MAX_STRENGTH;

use super::config::PresetSpec;
use super::report::{CurveReport, PresetReport, ShapeReport, StageRow};

/// The overlap thresholds of the curves: 0, 0.05, …, 1.
pub fn thresholds() -> Vec<f64> {
    (0..=20).map(|i| f64::from(i) / 20.0).collect()
}

/// The overlap at which the paper quotes repeatability (Section 4.3, Fig. 6).
pub const PAPER_OVERLAP: f64 = 0.8;

/// The records of preset `p`, in the paper's row order (then strength).
fn records(shapes: &[ShapeReport], p: usize) -> Vec<Record> {
    let mut r: Vec<Record> = shapes
        .iter()
        .filter(|s| s.kind != "null")
        .map(|s| Record {
            kind: s.kind.clone(),
            strength: s.strength,
            best_overlaps: s.presets[p].best_overlaps.clone(),
        })
        .collect();
    r.sort_by_key(|r| (row_order(&r.kind), r.kind.clone(), r.strength));
    r
}

/// The tables and curves of preset `p` over every transformed shape.
pub(super) fn preset_report(
    spec: &PresetSpec,
    p: usize,
    shapes: &[ShapeReport],
    thresholds: &[f64],
) -> PresetReport {
    let records = records(shapes, p);
    let mean_overlap = mean_overlap_table(&records);
    let mean_overlap_per_strength = per_strength_table(&records, &mean_overlap);
    let repeatability_at_0_8 = repeatability_table(&records, PAPER_OVERLAP);
    let component_counts = mean_overlap
        .rows
        .iter()
        .map(|row| {
            let counts = (1..=MAX_STRENGTH)
                .map(|s| {
                    records
                        .iter()
                        .filter(|r| r.kind == row.kind && (1..=s).contains(&r.strength))
                        .map(|r| r.best_overlaps.len())
                        .sum()
                })
                .collect();
            (row.kind.clone(), counts)
        })
        .collect();
    let curves = mean_overlap
        .rows
        .iter()
        .map(|row| {
            let pooled: Vec<f64> = records
                .iter()
                .filter(|r| r.kind == row.kind)
                .flat_map(|r| r.best_overlaps.iter().copied())
                .collect();
            CurveReport {
                kind: row.kind.clone(),
                label: row_label(&row.kind).to_owned(),
                components: pooled.len(),
                values: repeatability_curve(&pooled, thresholds),
            }
        })
        .collect();
    let stages = mean_overlap
        .rows
        .iter()
        .map(|row| {
            let of = |s: &&ShapeReport| s.kind == row.kind;
            let mean =
                |v: Vec<f64>| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
            StageRow {
                kind: row.kind.clone(),
                keypoints: mean(
                    shapes
                        .iter()
                        .filter(of)
                        .filter_map(|s| s.keypoint_share)
                        .collect(),
                ),
                clusters: mean(
                    shapes
                        .iter()
                        .filter(of)
                        .flat_map(|s| s.presets[p].cluster_overlaps.iter().copied())
                        .collect(),
                ),
                components: mean(
                    shapes
                        .iter()
                        .filter(of)
                        .flat_map(|s| s.presets[p].best_overlaps.iter().copied())
                        .collect(),
                ),
            }
        })
        .collect();
    PresetReport {
        stages,
        preset: spec.clone(),
        mean_overlap,
        mean_overlap_per_strength,
        repeatability_at_0_8,
        component_counts,
        curves,
        paper: paper_table(&spec.paper_name),
    }
}

/// Mean best overlap per kind (the rows of `layout`) and exact strength, with the mean row.
pub(super) fn per_strength_table(records: &[Record], layout: &CumulativeTable) -> CumulativeTable {
    let mean = |b: &[f64]| (!b.is_empty()).then(|| b.iter().sum::<f64>() / b.len() as f64);
    let rows: Vec<TableRow> = layout
        .rows
        .iter()
        .map(|row| TableRow {
            kind: row.kind.clone(),
            values: (1..=MAX_STRENGTH)
                .map(|s| {
                    let pooled: Vec<f64> = records
                        .iter()
                        .filter(|r| r.kind == row.kind && r.strength == s)
                        .flat_map(|r| r.best_overlaps.iter().copied())
                        .collect();
                    mean(&pooled)
                })
                .collect(),
        })
        .collect();
    let average = average_row(&rows, usize::from(MAX_STRENGTH));
    CumulativeTable { rows, average }
}
