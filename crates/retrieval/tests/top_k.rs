//! `rank` with a small `k` (candidates pruned by their score bound) returns exactly the first
//! `k` of the full ranking (every candidate matched): same shapes, same order, same scores.

use keycomp_describe::{DIM, Descriptor};
use keycomp_index::{ComponentRecord, ContentHash, IndexReader, IndexWriter, ShapeRecord};
use keycomp_retrieval::{MatchParams, ShapeView, rank, rank_hypotheses, record_areas};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn jitter(rng: &mut ChaCha8Rng, d: &Descriptor, amount: f32) -> Descriptor {
    std::array::from_fn(|i| d[i] + rng.random_range(-amount..amount))
}

/// Shapes of a few classes: each class has prototype parts in [0, 0.15)^D, so that parts of
/// one class are within matching distance of each other and of other classes' sometimes.
fn records(rng: &mut ChaCha8Rng, classes: &[Vec<Descriptor>], n: usize) -> Vec<ShapeRecord<DIM>> {
    (0..n)
        .map(|i| {
            let class = &classes[i % classes.len()];
            let m = rng.random_range(3..=class.len());
            let components: Vec<ComponentRecord<DIM>> = class[..m]
                .iter()
                .map(|p| ComponentRecord {
                    descriptor: jitter(rng, p, 0.04),
                    centre_vertex: 0,
                    area_fraction: 0.1,
                    keypoint_count: 1,
                    centre: None,
                })
                .collect();
            let mut layout = vec![0f32; m * m];
            for a in 0..m {
                for b in a + 1..m {
                    let d = (b - a) as f32 * rng.random_range(0.9..1.1);
                    layout[a * m + b] = d;
                    layout[b * m + a] = d;
                }
            }
            let name = format!("shape-{i:04}.off");
            ShapeRecord {
                path: name.clone().into(),
                canonical_path: format!("/{name}").into(),
                content_hash: ContentHash::of_bytes(name.as_bytes()),
                vertex_count: 100,
                face_count: 196,
                surface_area: 1.0,
                components,
                layout,
                sample: Vec::new(),
                boundary_vertices: 0,
            }
        })
        .collect()
}

/// An index of `shapes` records of `classes` classes with `parts` prototype parts each (see
/// [`records`]), in a temporary folder kept alive by the first value.
fn index(
    rng: &mut ChaCha8Rng,
    classes: usize,
    parts: usize,
    shapes: usize,
) -> (tempfile::TempDir, IndexReader<DIM>) {
    let classes: Vec<Vec<Descriptor>> = (0..classes)
        .map(|_| {
            (0..parts)
                .map(|_| std::array::from_fn(|_| rng.random_range(0.0..0.15)))
                .collect()
        })
        .collect();
    let dir = tempfile::tempdir().expect("tempdir");
    {
        let mut w = IndexWriter::<DIM>::create_or_open(dir.path()).expect("index");
        w.add_batch(records(rng, &classes, shapes)).expect("add");
    }
    let reader = IndexReader::<DIM>::open(dir.path()).expect("open");
    (dir, reader)
}

#[test]
fn pruned_top_k_equals_the_full_ranking() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (_dir, reader) = index(&mut rng, 5, 10, 150);
    let params = MatchParams::default();
    let mut pruned_any = false;
    for q in 0..12 {
        let src = reader.shapes().unwrap()[q * 7].record.clone();
        let descs: Vec<Descriptor> = src
            .components
            .iter()
            .map(|c| jitter(&mut rng, &c.descriptor, 0.03))
            .collect();
        let areas = record_areas(&src, &params);
        let view = ShapeView {
            descriptors: &descs,
            layout: &src.layout,
            areas: &areas,
            centres: &[],
            sample: &[],
        };
        let full = rank(&reader, view, 10_000, &params).expect("rank");
        assert!(full.len() > 10, "more candidates than the largest k");
        for k in [1, 3, 10] {
            let top = rank(&reader, view, k, &params).expect("rank");
            assert_eq!(top.len(), k);
            for (a, b) in top.iter().zip(&full) {
                assert_eq!(a.id, b.id, "query {q}, k {k}");
                assert_eq!(a.result, b.result, "query {q}, k {k}");
            }
        }
        pruned_any |= full[10].result.score > 0.0;
    }
    assert!(
        pruned_any,
        "the test must have candidates beyond the top 10 with a score"
    );
}

#[test]
fn hypotheses_rank_each_shape_by_its_best_score() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let (_dir, reader) = index(&mut rng, 4, 8, 60);
    let params = MatchParams::default();
    for q in 0..6 {
        // two descriptions of one query: the parts of two different shapes
        let srcs = [
            reader.shapes().unwrap()[q * 5].record.clone(),
            reader.shapes().unwrap()[q * 5 + 2].record.clone(),
        ];
        let descs: Vec<Vec<Descriptor>> = srcs
            .iter()
            .map(|s| {
                s.components
                    .iter()
                    .map(|c| jitter(&mut rng, &c.descriptor, 0.03))
                    .collect()
            })
            .collect();
        let areas: Vec<Vec<f32>> = srcs.iter().map(|s| record_areas(s, &params)).collect();
        let views: Vec<ShapeView> = (0..2)
            .map(|h| ShapeView {
                descriptors: &descs[h],
                layout: &srcs[h].layout,
                areas: &areas[h],
                centres: &[],
                sample: &[],
            })
            .collect();
        // the oracle: every shape's best score over the two full rankings
        let mut best: std::collections::BTreeMap<_, (f64, usize)> = Default::default();
        for (h, v) in views.iter().enumerate() {
            for r in rank(&reader, *v, 10_000, &params).expect("rank") {
                let e = best.entry(r.id).or_insert((r.result.score, h));
                if r.result.score > e.0 {
                    *e = (r.result.score, h);
                }
            }
        }
        let all = rank_hypotheses(&reader, &views, 10_000, &params).expect("rank");
        assert_eq!(all.len(), best.len(), "query {q}");
        for w in all.windows(2) {
            assert!(
                w[0].result.score >= w[1].result.score,
                "query {q}: best first"
            );
        }
        for r in &all {
            assert_eq!((r.result.score, r.hypothesis), best[&r.id], "query {q}");
        }
        assert!(
            all.iter().any(|r| r.hypothesis == 1),
            "query {q}: both used"
        );
        // one hypothesis: exactly rank's order
        let one = rank_hypotheses(&reader, &views[..1], 10_000, &params).expect("rank");
        let alone = rank(&reader, views[0], 10_000, &params).expect("rank");
        assert_eq!(
            one.iter().map(|r| r.id).collect::<Vec<_>>(),
            alone.iter().map(|r| r.id).collect::<Vec<_>>(),
            "query {q}"
        );
        // and the first k are the first k of the whole ranking
        let top = rank_hypotheses(&reader, &views, 5, &params).expect("rank");
        for (a, b) in top.iter().zip(&all) {
            assert_eq!((a.id, a.hypothesis), (b.id, b.hypothesis), "query {q}");
        }
    }
}
