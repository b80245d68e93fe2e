use super::*;
use crate::graph::dijkstra;
use crate::transform::{Kind, transform};
use keycomp_mesh::geometry::vertex_areas;
use keycomp_mesh::synth;
use proptest::prelude::*;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn overlap_of_identical_disjoint_and_nested_sets() {
    let areas = vec![1.0; 100];
    let a: Vec<u32> = (0..20).collect();
    let mut shuffled = a.clone();
    shuffled.reverse();
    shuffled.push(3); // duplicates are ignored
    assert!(close(overlap(&areas, &a, &shuffled), 1.0));
    let b: Vec<u32> = (20..40).collect();
    assert_eq!(overlap(&areas, &a, &b), 0.0);
    // A is half of B with uniform areas: IoU = 10 / 20
    let half: Vec<u32> = (0..10).collect();
    assert!(close(overlap(&areas, &half, &a), 0.5));
    // shifted by a third: |∩| = 10, |∪| = 30
    let shifted: Vec<u32> = (10..30).collect();
    assert!(close(overlap(&areas, &a, &shifted), 1.0 / 3.0));
    // empty sets and ids without an area
    assert_eq!(overlap(&areas, &[], &[]), 0.0);
    assert_eq!(overlap(&areas, &[500], &[500]), 0.0);
}

#[test]
fn overlap_weights_by_vertex_area() {
    // a 4×4 grid: the left half of the columns against everything
    let m = synth::grid(4, 4, 1.0);
    let areas = vertex_areas(&m);
    let all: Vec<u32> = (0..m.num_vertices() as u32).collect();
    let left: Vec<u32> = all.iter().copied().filter(|&v| v % 5 <= 2).collect();
    let expected = left.iter().map(|&v| areas[v as usize]).sum::<f64>() / 16.0;
    assert!(close(overlap(&areas, &left, &all), expected));
}

#[test]
fn best_overlaps_picks_the_best_null_component() {
    let areas = vec![1.0; 50];
    let null = vec![(0..10).collect::<Vec<u32>>(), (10..30).collect()];
    let carried = vec![
        (0..10).collect::<Vec<u32>>(), // identical to the first
        (10..20).collect(),            // half of the second
        (5..15).collect(),             // 5/15 with the first, 5/25 with the second
        (40..45).collect(),            // touches nothing
        vec![],
    ];
    let best = best_overlaps(&null, &carried, &areas);
    assert_eq!(best.len(), 5);
    assert!(close(best[0], 1.0));
    assert!(close(best[1], 0.5));
    assert!(close(best[2], 1.0 / 3.0));
    assert_eq!(best[3], 0.0);
    assert_eq!(best[4], 0.0);
    assert_eq!(best_overlaps(&[], &carried, &areas), vec![0.0; 5]);
    assert!(best_overlaps(&null, &[], &areas).is_empty());
}

#[test]
fn repeatability_counts_strictly_greater() {
    let best = [1.0, 0.9, 0.8, 0.5, 0.0];
    assert!(close(repeatability(&best, 0.8), 0.4));
    assert!(close(repeatability(&best, 0.0), 0.8));
    assert_eq!(repeatability(&[], 0.5), 0.0);
    assert_eq!(
        repeatability_curve(&best, &[0.0, 0.5, 0.95, 1.0]),
        vec![0.8, 0.6, 0.2, 0.0]
    );
}

proptest! {
    #[test]
    fn best_overlap_equals_brute_force(
        null in prop::collection::vec(prop::collection::vec(0u32..40, 0..15), 0..5),
        carried in prop::collection::vec(prop::collection::vec(0u32..40, 0..15), 0..5),
        weights in prop::collection::vec(0.0f64..2.0, 40),
    ) {
        let fast = best_overlaps(&null, &carried, &weights);
        for (c, f) in carried.iter().zip(&fast) {
            let slow = null.iter().map(|x| overlap(&weights, x, c)).fold(0.0, f64::max);
            prop_assert!((slow - f).abs() < 1e-9, "{} vs {}", slow, f);
            prop_assert!((0.0..=1.0).contains(f));
        }
    }
}

#[test]
fn identity_and_permutation_pullbacks_are_exact() {
    let m = synth::icosphere(3, 1.0);
    let t = Topology::new(&m);
    let n = m.num_vertices() as u32;
    let id: Vec<Option<u32>> = (0..n).map(Some).collect();
    let p = Pullback::new(&m, &t, &id).unwrap();
    let y: Vec<u32> = (0..n).filter(|v| v % 7 == 3).collect();
    assert_eq!(p.carry(&y), y);
    assert_eq!(p.num_transformed(), n as usize);
    // transformed vertex i is null vertex n-1-i
    let rev: Vec<Option<u32>> = (0..n).map(|i| Some(n - 1 - i)).collect();
    let p = Pullback::new(&m, &t, &rev).unwrap();
    let mut expected: Vec<u32> = y.iter().map(|&i| n - 1 - i).collect();
    expected.sort_unstable();
    assert_eq!(p.carry(&y), expected);
    assert_eq!(p.label(0), Some(n - 1));
    // out-of-range component ids are ignored; out-of-range map entries are an error
    assert_eq!(p.carry(&[n + 5]), Vec::<u32>::new());
    assert!(matches!(
        Pullback::new(&m, &t, &[Some(n)]),
        Err(BenchError::MapOutOfRange { .. })
    ));
}

#[test]
fn pullback_labels_unmapped_vertices_with_the_nearest_image() {
    // a 10 × 1 strip; only null vertices 0 and 10 (row 0 ends) have preimages 1 and 0
    let m = synth::grid(10, 1, 1.0);
    let t = Topology::new(&m);
    let mut map = vec![None; 3];
    map[1] = Some(0);
    map[0] = Some(10);
    let p = Pullback::new(&m, &t, &map).unwrap();
    assert_eq!(p.label(2), Some(1));
    assert_eq!(p.label(9), Some(0));
    let left = p.carry(&[1]);
    let right = p.carry(&[0]);
    assert!(left.contains(&0) && left.contains(&4) && !left.contains(&6));
    assert!(right.contains(&10) && right.contains(&6));
    // the two cells partition the strip; transformed vertex 2 has no image
    assert_eq!(left.len() + right.len(), m.num_vertices());
    assert!(p.carry(&[2]).is_empty());
}

/// A null region (a geodesic ball), its image in a transformed shape (the transformed vertices
/// mapped into it) and the overlap of the carried image with the region.
fn carried_image_overlap(null: &Mesh, kind: Kind, strength: u8, centre: u32, radius: f64) -> f64 {
    let topo = Topology::new(null);
    let mut region = Vec::new();
    dijkstra(&null.positions, &topo, &[(centre, 0)], radius, |v, _, _| {
        region.push(v);
        true
    });
    let mut inside = vec![false; null.num_vertices()];
    for &v in &region {
        inside[v as usize] = true;
    }
    let tr = transform(null, kind, strength, 11).unwrap();
    let image: Vec<u32> = (0..tr.map.len() as u32)
        .filter(|&t| tr.map[t as usize].is_some_and(|v| inside[v as usize]))
        .collect();
    let p = Pullback::new(null, &topo, &tr.map).unwrap();
    overlap(&vertex_areas(null), &region, &p.carry(&image))
}

#[test]
fn a_repeated_region_carries_back_from_a_decimated_shape() {
    let null = synth::icosphere(5, 1.0);
    for (s, min) in [(1, 0.9), (3, 0.85), (5, 0.8)] {
        for (centre, radius) in [(0, 0.5), (1234, 0.3)] {
            let o = carried_image_overlap(&null, Kind::Sampling, s, centre, radius);
            assert!(o > min, "sampling {s}: overlap {o}");
        }
    }
}

#[test]
fn a_repeated_region_carries_back_from_holed_shapes() {
    let null = synth::protrusion_sphere(4, 0.8, 0.25);
    for kind in [Kind::Holes, Kind::Microholes] {
        let o = carried_image_overlap(&null, kind, 5, 7, 0.6);
        assert!(o > 0.9, "{kind}: overlap {o}");
    }
    // identity-map kinds carry exactly
    let o = carried_image_overlap(&null, Kind::Noise, 5, 7, 0.6);
    assert!(close(o, 1.0));
}

#[test]
fn cumulative_tables_pool_strengths() {
    let rec = |kind: &str, strength, best: &[f64]| Record {
        kind: kind.to_owned(),
        strength,
        best_overlaps: best.to_vec(),
    };
    let records = vec![
        rec("noise", 1, &[1.0, 0.8]),
        rec("noise", 2, &[0.6]),
        rec("noise", 5, &[0.0]),
        rec("holes", 3, &[0.5]),
        rec("holes", 9, &[0.9]), // out of range: ignored
    ];
    let t = mean_overlap_table(&records);
    assert_eq!(t.rows.len(), 2);
    assert_eq!(t.rows[0].kind, "noise");
    let v = &t.rows[0].values;
    assert!(close(v[0].unwrap(), 0.9));
    assert!(close(v[1].unwrap(), 0.8));
    assert!(close(v[3].unwrap(), 0.8));
    assert!(close(v[4].unwrap(), 0.6));
    assert_eq!(t.rows[1].values[..2], [None, None]);
    assert!(close(t.rows[1].values[4].unwrap(), 0.5));
    assert!(close(t.average[0].unwrap(), 0.9));
    assert!(close(t.average[4].unwrap(), 0.55));
    let r = repeatability_table(&records, 0.7);
    assert!(close(r.rows[0].values[0].unwrap(), 1.0));
    assert!(close(r.rows[0].values[4].unwrap(), 0.5));
    assert_eq!(r.rows[1].values[2], Some(0.0));
    let json = serde_json::to_string(&t).unwrap();
    let back: CumulativeTable = serde_json::from_str(&json).unwrap();
    assert_eq!(back, t);
}

fn points(p: &[[f64; 3]]) -> Mesh {
    Mesh {
        positions: p
            .iter()
            .map(|&[x, y, z]| keycomp_mesh::Point3::new(x, y, z))
            .collect(),
        faces: Vec::new(),
    }
}

#[test]
fn each_vertex_goes_with_its_nearest_canonical_vertex() {
    // oracle: brute-force nearest neighbour
    let shape: Vec<[f64; 3]> = (0..50)
        .map(|i| {
            let t = i as f64 * 0.37;
            [t.sin(), t.cos(), 0.1 * t]
        })
        .collect();
    let canon: Vec<[f64; 3]> = (0..7)
        .map(|i| {
            let t = i as f64 * 2.6;
            [t.sin(), t.cos(), 0.1 * t]
        })
        .collect();
    let carrier = Pullback::nearest(&points(&shape), &points(&canon));
    let nearest = |p: &[f64; 3]| {
        (0..canon.len())
            .min_by(|&a, &b| {
                let d = |c: &[f64; 3]| (0..3).map(|k| (c[k] - p[k]).powi(2)).sum::<f64>();
                d(&canon[a]).total_cmp(&d(&canon[b]))
            })
            .unwrap() as VertexId
    };
    let component = [1, 4, 5];
    let expected: Vec<VertexId> = (0..shape.len() as VertexId)
        .filter(|&v| component.contains(&nearest(&shape[v as usize])))
        .collect();
    assert!(!expected.is_empty());
    assert_eq!(carrier.carry(&component), expected);
    // every vertex lies in exactly one cell
    let all: Vec<VertexId> = (0..canon.len() as VertexId).collect();
    assert_eq!(carrier.carry(&all).len(), shape.len());
    assert!(carrier.carry(&[99]).is_empty());
}

#[test]
fn the_same_vertices_carry_onto_themselves() {
    let p = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 2.0, 0.0],
        [0.0, 0.0, 3.0],
    ];
    let carrier = Pullback::nearest(&points(&p), &points(&p));
    assert_eq!(carrier.carry(&[2, 0]), vec![0, 2]);
}
