//! The KD-tree search returns what a linear scan returns.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use keycomp_index::{ComponentRecord, IndexReader, IndexWriter, ShapeRecord, synthetic};
use proptest::prelude::*;

const D: usize = 6;

fn shape(i: usize, descriptors: &[[f32; D]]) -> ShapeRecord<D> {
    let mut r = synthetic::record::<D>(3, i as u64);
    r.components = descriptors
        .iter()
        .map(|d| ComponentRecord {
            descriptor: *d,
            centre_vertex: 0,
            area_fraction: 0.1,
            keypoint_count: 3,
            centre: None,
        })
        .collect();
    let m = descriptors.len();
    r.layout = vec![0.0; m * m];
    r
}

fn check(shapes: Vec<Vec<[f32; D]>>, queries: Vec<[f32; D]>, k: usize) {
    let tmp = tempfile::tempdir().unwrap();
    let mut w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    let recs: Vec<_> = shapes
        .iter()
        .enumerate()
        .map(|(i, d)| shape(i, d))
        .collect();
    // Two segments, so the tree spans files.
    let half = recs.len() / 2;
    let mut recs = recs;
    let second = recs.split_off(half);
    w.add_batch(recs).unwrap();
    w.add_batch(second).unwrap();
    drop(w);
    let r = IndexReader::<D>::open(tmp.path()).unwrap();
    for q in &queries {
        let tree = r.nearest_components(q, k).unwrap();
        let scan = r.nearest_linear(q, k);
        assert_eq!(tree.len(), scan.len());
        let dt: Vec<f32> = tree.iter().map(|m| m.distance_sq).collect();
        let ds: Vec<f32> = scan.iter().map(|m| m.distance_sq).collect();
        assert_eq!(dt, ds, "query {q:?}");
        // Every reported distance is the true one for the reported component.
        for m in &tree {
            let d = r.get(m.shape).unwrap().unwrap().components[m.component].descriptor;
            assert_eq!(m.distance_sq, keycomp_index::squared_distance(q, &d));
        }
    }
    // A memory-mapped snapshot, whose search reads the descriptors in place, finds the same,
    // exactly and approximately.
    let mapped = IndexReader::<D>::open_mapped(tmp.path()).unwrap();
    assert_eq!(mapped.component_count(), r.component_count());
    let approx = IndexReader::<D>::open(tmp.path())
        .unwrap()
        .with_search_mode(keycomp_index::SearchMode::Approximate);
    let mapped_approx = IndexReader::<D>::open_mapped(tmp.path())
        .unwrap()
        .with_search_mode(keycomp_index::SearchMode::Approximate);
    for q in &queries {
        assert_eq!(
            mapped.nearest_components(q, k).unwrap(),
            r.nearest_components(q, k).unwrap()
        );
        assert_eq!(
            mapped_approx.nearest_components(q, k).unwrap(),
            approx.nearest_components(q, k).unwrap()
        );
    }
}

fn descriptor() -> impl Strategy<Value = [f32; D]> {
    // A coarse grid gives many exact ties and duplicates; the range part gives generic points.
    prop_oneof![
        prop::array::uniform6((0u8..4).prop_map(|v| f32::from(v) * 0.25)),
        prop::array::uniform6(-1.0f32..1.0),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn tree_equals_linear_scan(
        shapes in prop::collection::vec(prop::collection::vec(descriptor(), 0..8), 1..60),
        queries in prop::collection::vec(descriptor(), 1..6),
        k in 1usize..40,
    ) {
        check(shapes, queries, k);
    }
}

#[test]
fn many_identical_descriptors() {
    // All-equal descriptors (e.g. degenerate components) must not break the tree.
    let shapes = vec![vec![[0.0f32; D]; 8]; 50];
    check(shapes, vec![[0.0; D], [1.0; D]], 17);
}

#[test]
fn non_finite_query_is_an_error() {
    let tmp = tempfile::tempdir().unwrap();
    let mut w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    w.add_batch(vec![shape(0, &[[0.5; D]])]).unwrap();
    drop(w);
    let r = IndexReader::<D>::open(tmp.path()).unwrap();
    let mut q = [0.0; D];
    q[3] = f32::NAN;
    assert!(r.nearest_components(&q, 1).is_err());
    assert!(r.nearest_components(&[0.0; D], 0).unwrap().is_empty());
}
