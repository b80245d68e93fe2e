//! Transformations and the pullback on real meshes from `../shared/data` (skipped with a
//! message when the folder is absent).

use keycomp_bench::{Kind, Pullback, overlap, transform};
use keycomp_mesh::geometry::{total_area, vertex_areas};
use keycomp_mesh::{Mesh, Topology, read_mesh};
use keycomp_test_support::shared_data;

/// The shared mesh `rel`, or `None` after a skip message when it is absent.
fn shared(rel: &str) -> Option<Mesh> {
    let path = shared_data(rel)?;
    Some(read_mesh(&path).expect("shared mesh reads").mesh)
}

/// Edges with more than two faces.
fn nonmanifold_edges(m: &Mesh) -> usize {
    let t = Topology::new(m);
    (0..m.num_vertices() as u32)
        .map(|v| t.edge_face_counts(v).iter().filter(|&&c| c > 2).count())
        .sum::<usize>()
        / 2
}

#[test]
fn every_kind_on_tosca_cat0() {
    let Some(null) = shared("tosca/cat0.off") else {
        return;
    };
    let n = null.num_vertices();
    let mut sampled = Vec::new();
    for kind in Kind::ALL {
        for s in [1u8, 3, 5] {
            let t = transform(&null, kind, s, 42).unwrap_or_else(|e| panic!("{kind} {s}: {e}"));
            assert_eq!(t.map.len(), t.mesh.num_vertices());
            let mut seen = vec![false; n];
            for (i, m) in t.map.iter().enumerate() {
                let v = m.expect("every vertex mapped") as usize;
                assert!(v < n && !seen[v]);
                seen[v] = true;
                if kind.keeps_positions() {
                    assert_eq!(t.mesh.positions[i], null.positions[v]);
                }
            }
            let (_, rep) = Mesh::from_raw(t.mesh.positions.clone(), t.mesh.faces.clone())
                .expect("valid output");
            assert_eq!(rep.dropped_faces(), 0);
            if kind == Kind::Sampling {
                sampled.push(t.mesh.num_vertices());
            }
            if matches!(kind, Kind::Sampling | Kind::Topology) {
                assert!(
                    nonmanifold_edges(&t.mesh) <= nonmanifold_edges(&null),
                    "{kind} {s}"
                );
            }
            if kind == Kind::Holes {
                let removed = 1.0 - total_area(&t.mesh) / total_area(&null);
                assert!(removed >= 0.02 * f64::from(s), "{removed}");
            }
        }
    }
    assert!(sampled.windows(2).all(|w| w[1] < w[0]), "{sampled:?}");
}

#[test]
fn decimated_cat_regions_carry_back() {
    let Some(null) = shared("tosca/cat0.off") else {
        return;
    };
    let topo = Topology::new(&null);
    let areas = vertex_areas(&null);
    let t = transform(&null, Kind::Sampling, 4, 0).expect("sampling");
    let p = Pullback::new(&null, &topo, &t.map).expect("pullback");
    // regions: blocks of null vertices by position along the longest axis
    let xs: Vec<f64> = null.positions.iter().map(|q| q.x).collect();
    let (lo, hi) = xs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    for k in 0..4 {
        let (a, b) = (
            lo + (hi - lo) * k as f64 / 4.0,
            lo + (hi - lo) * (k + 1) as f64 / 4.0,
        );
        let region: Vec<u32> = (0..null.num_vertices() as u32)
            .filter(|&v| (a..b).contains(&xs[v as usize]))
            .collect();
        let image: Vec<u32> = (0..t.map.len() as u32)
            .filter(|&i| t.map[i as usize].is_some_and(|v| (a..b).contains(&xs[v as usize])))
            .collect();
        let o = overlap(&areas, &region, &p.carry(&image));
        assert!(o > 0.9, "slab {k}: {o}");
    }
}
