//! Harris 3D on real meshes from `../shared/data` (skipped with a message when absent):
//! repeatability between two poses of the TOSCA cat, which share their vertex numbering.

use keycomp_harris::{HarrisParams, HarrisResult, LengthReference, detect};
use keycomp_mesh::geometry::total_area;
use keycomp_mesh::{Mesh, Topology, read_mesh};
use keycomp_test_support::{edge_path_distances, median, shared_data};

fn load(path: &std::path::Path) -> Mesh {
    read_mesh(path)
        .unwrap_or_else(|e| panic!("{}: {e:#}", path.display()))
        .mesh
}

/// Edge-hop distance from the nearest source, up to `max_hops` (u32::MAX beyond).
fn hops_from(topo: &Topology, sources: &[u32], max_hops: u32) -> Vec<u32> {
    let mut hops = vec![u32::MAX; topo.num_vertices()];
    let mut frontier: Vec<u32> = sources.to_vec();
    for &s in sources {
        hops[s as usize] = 0;
    }
    for h in 1..=max_hops {
        let mut next = Vec::new();
        for &u in &frontier {
            for &w in topo.neighbors(u) {
                if hops[w as usize] == u32::MAX {
                    hops[w as usize] = h;
                    next.push(w);
                }
            }
        }
        frontier = next;
    }
    hops
}

struct Repeatability {
    same_vertex: f64,
    within_2_rings: f64,
    median_distance: f64,
    within_distance: f64,
}

fn repeatability(
    null: &Mesh,
    topo: &Topology,
    a: &HarrisResult,
    b: &HarrisResult,
) -> Repeatability {
    let hops = hops_from(topo, &a.keypoints, 2);
    let near = b
        .keypoints
        .iter()
        .filter(|&&k| hops[k as usize] <= 2)
        .count();
    // distances on the null shape, in unit-area units
    let s = 1.0 / total_area(null).sqrt();
    // shortest edge-path length from the nearest keypoint of a: a cheap upper bound on
    // geodesic distance (a few % long on regular meshes)
    let dist = edge_path_distances(&null.positions, &null.faces, &a.keypoints);
    let d: Vec<f64> = b.keypoints.iter().map(|&k| dist[k as usize] * s).collect();
    let radius = 0.02; // 2 % of √area
    Repeatability {
        same_vertex: b
            .keypoints
            .iter()
            .filter(|&&k| hops[k as usize] == 0)
            .count() as f64
            / b.keypoints.len() as f64,
        within_2_rings: near as f64 / b.keypoints.len() as f64,
        median_distance: median(d.clone()),
        within_distance: d.iter().filter(|&&x| x <= radius).count() as f64 / d.len() as f64,
    }
}

#[test]
fn cat_poses_share_most_keypoints() {
    let Some(dir) = shared_data("") else { return };
    let (p0, p3) = (dir.join("tosca/cat0.off"), dir.join("tosca/cat3.off"));
    if !p0.is_file() || !p3.is_file() {
        println!("skipping: TOSCA cat0/cat3 not found in {}", dir.display());
        return;
    }
    let (cat0, cat3) = (load(&p0), load(&p3));
    assert_eq!(cat0.num_vertices(), cat3.num_vertices());
    let (t0, t3) = (Topology::new(&cat0), Topology::new(&cat3));
    let variants = [
        (
            "default (moment diagonal, ≥2 rings, ≥12 points)",
            HarrisParams::default(),
        ),
        (
            "bounding-box diagonal, ≥2 rings, ≥12 points",
            HarrisParams {
                length_reference: LengthReference::BoundingBoxDiagonal,
                ..HarrisParams::default()
            },
        ),
        (
            "authors' neighbourhoods (box, ≥1 ring, ≥6 points)",
            HarrisParams {
                length_reference: LengthReference::BoundingBoxDiagonal,
                min_rings: 1,
                min_points: 6,
                ..HarrisParams::default()
            },
        ),
    ];
    let mut default_rate = 0.0;
    println!("cat0: {} vertices", cat0.num_vertices());
    for (name, params) in variants {
        let r0 = detect(&cat0, &t0, &params).expect("valid");
        let r3 = detect(&cat3, &t3, &params).expect("valid");
        let rep = repeatability(&cat0, &t0, &r0, &r3);
        println!(
            "{name}: cat0 {} keypoints, cat3 {}; cat3 keypoints within 2 rings of a cat0 \
             keypoint: {:.1} % (authors' code: 86 %); same vertex: {:.1} %; within edge-path distance 0.02·√area: \
             {:.1} %; median distance {:.4}·√area",
            r0.keypoints.len(),
            r3.keypoints.len(),
            100.0 * rep.within_2_rings,
            100.0 * rep.same_vertex,
            100.0 * rep.within_distance,
            rep.median_distance,
        );
        if params == HarrisParams::default() {
            default_rate = rep.within_2_rings;
            // 1 % of 27,894 vertices
            assert_eq!(r0.keypoints.len(), 279);
        }
    }
    assert!(default_rate >= 0.6, "repeatability {default_rate}");
}

#[test]
fn models_have_finite_responses() {
    let Some(dir) = shared_data("") else { return };
    for name in ["bunny.off", "fandisk.off", "camelhead.off"] {
        let p = dir.join("models").join(name);
        if !p.is_file() {
            println!("skipping {name}: not found");
            continue;
        }
        let m = load(&p);
        let t = Topology::new(&m);
        let r = detect(&m, &t, &HarrisParams::default()).expect("valid");
        let nan = r.response.iter().filter(|h| h.is_nan()).count();
        println!(
            "{name}: {} vertices, {} keypoints, {nan} without a response",
            m.num_vertices(),
            r.keypoints.len()
        );
        assert!(r.response.iter().all(|h| !h.is_infinite()));
        assert!(nan * 100 < m.num_vertices(), "{name}: {nan} NaN responses");
        assert!(!r.keypoints.is_empty());
    }
}
