//! The whole run: load the null shapes, list every shape to evaluate, run them (in parallel
//! when asked), score each transformed shape against its null shape and assemble the
//! [`Report`].

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use keycomp_mesh::geometry::vertex_areas;
use keycomp_mesh::{Topology, VertexId, read_mesh};
use rayon::prelude::*;

use super::config::{Config, referenced};
use super::discover::NullSpec;
use super::report::{
    CLUSTER_RADIUS, KEYPOINT_RADIUS, PresetScores, REPORT_FORMAT, Report, RunStats, ShapeReport,
    Skipped,
};
use super::score::{preset_report, thresholds};
use super::shape::{CacheUse, Job, LoadedNull, Outcome, REMESHED_POSE_DENSITY, Source};
use crate::error::BenchError;
use crate::evaluate::{best_overlaps, share_within, within};
use crate::transform::MAX_STRENGTH;

/// A null shape's stage regions: its vertices near its keypoints, and per preset the regions of
/// its clusters.
type NullStages = (Vec<VertexId>, Vec<Vec<Vec<VertexId>>>);

/// Progress of a run, reported after each shape.
#[derive(Debug, Clone, Copy)]
pub struct Progress<'a> {
    /// Shapes finished.
    pub done: usize,
    /// Shapes in the run.
    pub total: usize,
    /// The shape just finished (`cat0 holes 3`).
    pub shape: &'a str,
}

/// Runs the experiment on `nulls` (see *Run* in the [module docs](super)); `progress` is called after
/// every shape, from worker threads.
///
/// Errors: a null shape's file cannot be read, or a strength is out of range. Failures of
/// single shapes (a transformation that does not apply, a detection error) are reported in
/// [`Report::skipped`] instead.
pub fn run(
    config: &Config,
    nulls: &[NullSpec],
    progress: &(dyn Fn(Progress<'_>) + Sync),
) -> Result<(Report, RunStats), BenchError> {
    let t0 = Instant::now();
    if let Some(&strength) = config
        .strengths
        .iter()
        .find(|s| !(1..=MAX_STRENGTH).contains(*s))
    {
        return Err(BenchError::InvalidStrength { strength });
    }
    let loaded: Vec<LoadedNull> = nulls
        .iter()
        .map(|spec| -> Result<LoadedNull, BenchError> {
            let mesh = read_mesh(&spec.path)?.mesh;
            let topo = Topology::new(&mesh);
            let areas = vertex_areas(&mesh);
            let referenced = referenced(&mesh);
            Ok(LoadedNull {
                spec: spec.clone(),
                mesh,
                topo,
                areas,
                referenced,
            })
        })
        .collect::<Result<_, _>>()?;

    let mut jobs = Vec::new();
    for (i, null) in loaded.iter().enumerate() {
        jobs.push(Job {
            null: i,
            source: Source::Null,
        });
        if config.isometry {
            for pose in &null.spec.poses {
                if config.strengths.contains(&pose.strength) {
                    jobs.push(Job {
                        null: i,
                        source: Source::Pose(pose.strength, pose.path.clone()),
                    });
                }
            }
        }
        if config.remeshed_isometry {
            for pose in &null.spec.poses {
                if config.strengths.contains(&pose.strength) {
                    jobs.push(Job {
                        null: i,
                        source: Source::Remeshed {
                            strength: pose.strength,
                            pose: Some(pose.path.clone()),
                        },
                    });
                }
            }
        }
        if config.retessellation {
            for &s in &config.strengths {
                jobs.push(Job {
                    null: i,
                    source: Source::Remeshed {
                        strength: s,
                        pose: None,
                    },
                });
            }
        }
        for &kind in &config.kinds {
            for &s in &config.strengths {
                jobs.push(Job {
                    null: i,
                    source: Source::Generated(kind, s),
                });
            }
        }
    }

    let done = AtomicUsize::new(0);
    let total = jobs.len();
    let work = |job: &Job| {
        let out = config.run_job(job, &loaded);
        let name = match job.source {
            Source::Null => loaded[job.null].spec.name.clone(),
            _ => format!(
                "{} {} {}",
                loaded[job.null].spec.name,
                job.kind(),
                job.strength()
            ),
        };
        progress(Progress {
            done: done.fetch_add(1, Ordering::Relaxed) + 1,
            total,
            shape: &name,
        });
        out
    };
    let outcomes: Vec<Result<Outcome, String>> = if config.parallel_shapes {
        jobs.par_iter().map(work).collect()
    } else {
        jobs.iter().map(work).collect()
    };

    // the null shapes' components, per null and preset
    let mut null_components: Vec<Option<&Vec<Vec<Vec<VertexId>>>>> = vec![None; loaded.len()];
    let mut null_outcome: Vec<Option<&Outcome>> = vec![None; loaded.len()];
    for (job, out) in jobs.iter().zip(&outcomes) {
        if let (Source::Null, Ok(o)) = (&job.source, out) {
            null_components[job.null] = Some(&o.components);
            null_outcome[job.null] = Some(o);
        }
    }
    // per null: its vertices near its keypoints, and per preset its clusters' regions
    let unit = |null: &LoadedNull| null.areas.iter().sum::<f64>().sqrt();
    let regions = |null: &LoadedNull, keys: &[VertexId]| {
        within(
            &null.mesh.positions,
            &null.topo,
            keys,
            CLUSTER_RADIUS * unit(null),
        )
    };
    let null_stages: Vec<Option<NullStages>> = loaded
        .iter()
        .zip(&null_outcome)
        .map(|(null, o)| {
            o.map(|o| {
                let near = within(
                    &null.mesh.positions,
                    &null.topo,
                    &o.keypoints_on_null,
                    KEYPOINT_RADIUS * unit(null),
                );
                let clusters = o
                    .clusters
                    .iter()
                    .map(|per| per.iter().map(|k| regions(null, k)).collect())
                    .collect();
                (near, clusters)
            })
        })
        .collect();
    let mut stats = RunStats::default();
    let mut shapes = Vec::new();
    let mut skipped = Vec::new();
    for (job, out) in jobs.iter().zip(&outcomes) {
        let null = &loaded[job.null];
        let skip = |reason: String| Skipped {
            null: null.spec.name.clone(),
            kind: job.kind().to_owned(),
            strength: job.strength(),
            reason,
        };
        let o = match (out, null_components[job.null]) {
            (Err(reason), _) => {
                skipped.push(skip(reason.clone()));
                continue;
            }
            (Ok(_), None) => {
                skipped.push(skip("the null shape itself could not be evaluated".into()));
                continue;
            }
            (Ok(o), Some(_)) => o,
        };
        match o.cache {
            CacheUse::Hit => stats.cache_hits += 1,
            CacheUse::Corrupt => {
                stats.corrupt_entries += 1;
                stats.computed += 1;
            }
            CacheUse::Miss | CacheUse::Off => stats.computed += 1,
        }
        stats.cache_write_errors.extend(o.cache_error.clone());
        stats.shape_seconds += o.seconds;
        let is_null = matches!(job.source, Source::Null);
        let stage = null_stages[job.null].as_ref().filter(|_| !is_null);
        let presets = o
            .components
            .iter()
            .enumerate()
            .map(|(p, comps)| PresetScores {
                components: comps.len(),
                best_overlaps: match (&job.source, null_components[job.null]) {
                    (Source::Null, _) | (_, None) => Vec::new(),
                    (_, Some(nc)) => best_overlaps(&nc[p], comps, &null.areas),
                },
                cluster_overlaps: match (stage, o.clusters.get(p)) {
                    (Some((_, null_clusters)), Some(keys)) if !keys.is_empty() => {
                        let mine: Vec<Vec<VertexId>> =
                            keys.iter().map(|k| regions(null, k)).collect();
                        best_overlaps(&null_clusters[p], &mine, &null.areas)
                    }
                    _ => Vec::new(),
                },
            })
            .collect();
        let keypoint_share = stage.and_then(|(near, _)| share_within(near, &o.keypoints_on_null));
        shapes.push(ShapeReport {
            null: null.spec.name.clone(),
            kind: job.kind().to_owned(),
            strength: job.strength(),
            source: match &job.source {
                Source::Pose(_, p) => p.display().to_string(),
                Source::Remeshed { strength, pose } => {
                    let (original, density) = match pose {
                        Some(p) => (p.as_path(), REMESHED_POSE_DENSITY),
                        None => (null.spec.path.as_path(), *strength),
                    };
                    config
                        .remeshed_file(original, density)
                        .map_or_else(String::new, |f| f.display().to_string())
                }
                _ => null.spec.path.display().to_string(),
            },
            vertices: o.vertices,
            faces: o.faces,
            keypoints: o.keypoints,
            keypoint_share,
            presets,
        });
    }

    let thresholds = thresholds();
    let presets = config
        .presets
        .iter()
        .enumerate()
        .map(|(p, spec)| preset_report(spec, p, &shapes, &thresholds))
        .collect();
    stats.seconds = t0.elapsed().as_secs_f64();
    let report = Report {
        format: REPORT_FORMAT,
        seed: config.seed,
        budget: config.budget.describe(),
        budget_rule: config.budget,
        harris: config.harris,
        smacof: config.smacof.clone(),
        geodesic: config.geodesic,
        mser: config.mser,
        surface: config.surface,
        thresholds,
        nulls: nulls.to_vec(),
        presets,
        shapes,
        skipped,
    };
    Ok((report, stats))
}
