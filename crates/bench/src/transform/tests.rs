use super::*;
use keycomp_mesh::geometry::total_area;
use keycomp_mesh::synth;

/// Checks everything a transformed shape promises; returns it for further checks.
pub(crate) fn check(null: &Mesh, kind: Kind, s: u8, seed: u64) -> Transformed {
    let t = transform(null, kind, s, seed).unwrap_or_else(|e| panic!("{kind} {s}: {e}"));
    let n = t.mesh.num_vertices();
    assert_eq!(t.map.len(), n, "{kind} {s}: map length");
    let mut seen = vec![false; null.num_vertices()];
    for (i, m) in t.map.iter().enumerate() {
        let v = m.unwrap_or_else(|| panic!("{kind} {s}: vertex {i} unmapped")) as usize;
        assert!(v < null.num_vertices(), "{kind} {s}: id out of range");
        assert!(!seen[v], "{kind} {s}: null vertex {v} mapped twice");
        seen[v] = true;
        if kind.keeps_positions() {
            assert_eq!(t.mesh.positions[i], null.positions[v], "{kind} {s}: moved");
        }
    }
    let (_, repairs) = Mesh::from_raw(t.mesh.positions.clone(), t.mesh.faces.clone())
        .unwrap_or_else(|e| panic!("{kind} {s}: invalid output: {e}"));
    assert_eq!(repairs.dropped_faces(), 0, "{kind} {s}");
    assert_eq!(
        transform(null, kind, s, seed).unwrap(),
        t,
        "{kind} {s}: not deterministic"
    );
    t
}

/// Edge-face counts of a mesh: (edges with 1 face, edges with 2, edges with more).
fn edge_kinds(m: &Mesh) -> (usize, usize, usize) {
    let t = Topology::new(m);
    let mut c = (0, 0, 0);
    for v in 0..m.num_vertices() as u32 {
        for (&w, &k) in t.neighbors(v).iter().zip(t.edge_face_counts(v)) {
            if v < w {
                match k {
                    1 => c.0 += 1,
                    2 => c.1 += 1,
                    _ => c.2 += 1,
                }
            }
        }
    }
    c
}

fn euler(m: &Mesh) -> i64 {
    let (a, b, c) = edge_kinds(m);
    m.num_vertices() as i64 - (a + b + c) as i64 + m.num_faces() as i64
}

fn two_spheres(gap: f64) -> Mesh {
    let a = synth::icosphere(4, 1.0);
    let mut positions = a.positions.clone();
    let off = a.positions.len() as u32;
    positions.extend(
        a.positions
            .iter()
            .map(|p| Point3::new(p.x + 2.0 + gap, p.y, p.z)),
    );
    let mut faces = a.faces.clone();
    faces.extend(a.faces.iter().map(|f| f.map(|v| v + off)));
    Mesh { positions, faces }
}

#[test]
fn names_parse_and_print() {
    for k in Kind::ALL {
        assert_eq!(k.to_string().parse::<Kind>().unwrap(), k);
        assert_eq!(serde_json::to_string(&k).unwrap(), format!("\"{k}\""));
    }
    assert_eq!(" Holes ".parse::<Kind>().unwrap(), Kind::Holes);
    let e = "isometry".parse::<Kind>().unwrap_err();
    assert!(e.to_string().contains("unknown transformation 'isometry'"));
}

#[test]
fn strength_and_area_are_checked() {
    let m = synth::icosphere(1, 1.0);
    for s in [0, 6] {
        assert!(matches!(
            transform(&m, Kind::Noise, s, 0),
            Err(BenchError::InvalidStrength { .. })
        ));
    }
    let flat = Mesh {
        positions: vec![Point3::origin(); 3],
        faces: vec![[0, 1, 2]],
    };
    assert!(matches!(
        transform(&flat, Kind::Noise, 1, 0),
        Err(BenchError::ZeroArea)
    ));
}

#[test]
fn every_kind_keeps_a_valid_map_on_synthetic_shapes() {
    let shapes = [
        ("icosphere5", synth::icosphere(5, 1.0)),
        ("protrusions", synth::protrusion_sphere(4, 0.8, 0.25)),
    ];
    for (name, null) in &shapes {
        for kind in Kind::ALL {
            for s in 1..=5 {
                if kind == Kind::Topology {
                    // convex-ish shapes have nothing to weld: a clear error, never a bad mesh
                    match transform(null, kind, s, 3) {
                        Ok(_) => {
                            check(null, kind, s, 3);
                        }
                        Err(BenchError::NothingToWeld { needed, found }) => {
                            assert!(found < needed, "{name}")
                        }
                        Err(e) => panic!("{name}: {e}"),
                    }
                } else {
                    check(null, kind, s, 3);
                }
            }
        }
    }
}

#[test]
fn holes_remove_growing_area_and_keep_a_manifold() {
    let null = synth::icosphere(5, 1.0);
    let a0 = total_area(&null);
    let mut last = 0.0;
    for s in 1..=5u8 {
        let t = check(&null, Kind::Holes, s, 9);
        let removed = 1.0 - total_area(&t.mesh) / a0;
        let nominal = 0.02 * f64::from(s);
        assert!(removed > last, "strength {s}: {removed} after {last}");
        assert!(
            removed >= nominal && removed < nominal + 0.02,
            "strength {s}: {removed}"
        );
        let (boundary, _, nonmanifold) = edge_kinds(&t.mesh);
        assert!(boundary > 0 && nonmanifold == 0);
        last = removed;
    }
    // different seeds, different holes
    assert_ne!(
        transform(&null, Kind::Holes, 3, 1).unwrap().map,
        transform(&null, Kind::Holes, 3, 2).unwrap().map
    );
}

#[test]
fn microholes_are_many_separate_small_holes() {
    let null = synth::icosphere(5, 1.0); // 10,242 vertices: 0.2 %·S·n = 21·S holes
    let topo = Topology::new(&null);
    let mut last = 0;
    for s in 1..=5u8 {
        let t = check(&null, Kind::Microholes, s, 4);
        let removed = null.num_vertices() - t.mesh.num_vertices();
        assert_eq!(removed, (0.002 * f64::from(s) * 10242.0).ceil() as usize);
        assert!(removed > last);
        last = removed;
        // every removed vertex's neighbours survive: holes are single-vertex stars
        let mut kept = vec![false; null.num_vertices()];
        for m in &t.map {
            kept[m.unwrap() as usize] = true;
        }
        for v in 0..null.num_vertices() as u32 {
            if !kept[v as usize] {
                assert!(topo.neighbors(v).iter().all(|&w| kept[w as usize]));
            }
        }
    }
}

#[test]
fn noise_grows_with_strength() {
    let null = synth::icosphere(5, 1.0);
    let unit = total_area(&null).sqrt();
    let rms = |s: u8| {
        let t = check(&null, Kind::Noise, s, 5);
        let sum: f64 = t
            .mesh
            .positions
            .iter()
            .zip(&null.positions)
            .map(|(a, b)| (a - b).norm_squared())
            .sum();
        (sum / (3.0 * null.num_vertices() as f64)).sqrt() / unit
    };
    let r: Vec<f64> = (1..=5).map(rms).collect();
    for (i, x) in r.iter().enumerate() {
        let sigma = 0.001 * (i + 1) as f64;
        assert!(
            (x / sigma - 1.0).abs() < 0.03,
            "σ {sigma}: rms per coordinate {x}"
        );
    }
}

#[test]
fn shot_noise_moves_a_growing_fraction_far() {
    let null = synth::icosphere(5, 1.0);
    let unit = total_area(&null).sqrt();
    for s in 1..=5u8 {
        let t = check(&null, Kind::Shotnoise, s, 6);
        let moved: Vec<f64> = t
            .mesh
            .positions
            .iter()
            .zip(&null.positions)
            .map(|(a, b)| (a - b).norm() / unit)
            .filter(|d| *d > 0.0)
            .collect();
        assert_eq!(
            moved.len(),
            (0.01 * f64::from(s) * 10242.0).round() as usize
        );
        assert!(moved.iter().all(|d| (d - 0.02).abs() < 1e-9));
    }
}

#[test]
fn scale_and_local_scale_change_areas_as_documented() {
    let null = synth::protrusion_sphere(4, 0.8, 0.25);
    let a0 = total_area(&null);
    for s in 1..=5u8 {
        let t = check(&null, Kind::Scale, s, 0);
        let f = decimate_free_factor(s);
        assert!((total_area(&t.mesh) / a0 - f * f).abs() < 1e-9);
    }
    let mut last = 0;
    for s in 1..=5u8 {
        let t = check(&null, Kind::Localscale, s, 8);
        let moved = t
            .mesh
            .positions
            .iter()
            .zip(&null.positions)
            .filter(|(a, b)| (*a - *b).norm() > 1e-12)
            .count();
        assert!(moved > last, "strength {s}: {moved} moved");
        assert!(total_area(&t.mesh) > a0);
        last = moved;
    }
}

fn decimate_free_factor(s: u8) -> f64 {
    displace::SCALE_FACTORS[usize::from(s) - 1]
}

#[test]
fn sampling_really_reduces_the_vertex_count() {
    for null in [
        synth::icosphere(5, 1.0),
        synth::protrusion_sphere(4, 0.8, 0.25),
    ] {
        let n = null.num_vertices();
        let mut last = n;
        for s in 1..=5u8 {
            let t = check(&null, Kind::Sampling, s, 0);
            let m = t.mesh.num_vertices();
            let target = decimate::KEEP[usize::from(s) - 1] * n as f64;
            assert!(m < last, "strength {s}: {m} after {last}");
            assert!(
                (m as f64 - target).abs() <= 0.01 * n as f64,
                "strength {s}: {m} for {target}"
            );
            // a closed manifold sphere stays one
            assert_eq!(edge_kinds(&t.mesh), (0, edge_kinds(&t.mesh).1, 0));
            assert_eq!(euler(&t.mesh), 2);
            last = m;
        }
    }
}

#[test]
fn sampling_keeps_boundaries_manifold() {
    let null = synth::height_field(60, 60, 0.1, |x, y| 0.3 * (x * 2.0).sin() * y.cos());
    let (b0, _, _) = edge_kinds(&null);
    let mut last = null.num_vertices();
    for s in 1..=5u8 {
        let t = check(&null, Kind::Sampling, s, 0);
        let (b, _, more) = edge_kinds(&t.mesh);
        assert_eq!(more, 0);
        assert!(b > 0 && b <= b0);
        assert_eq!(euler(&t.mesh), 1, "still a disc");
        assert!(t.mesh.num_vertices() < last);
        last = t.mesh.num_vertices();
    }
}

#[test]
fn topology_welds_nearby_pieces_with_manifold_handles() {
    let null = two_spheres(0.05);
    assert_eq!(Topology::new(&null).connected_components().1, 2);
    for s in 1..=5u8 {
        let t = check(&null, Kind::Topology, s, 2);
        assert_eq!(t.mesh.positions, null.positions);
        let h = 2 * usize::from(s);
        assert_eq!(t.mesh.num_faces(), null.num_faces() + 4 * h);
        let (b, _, more) = edge_kinds(&t.mesh);
        assert_eq!((b, more), (0, 0));
        // two spheres (χ = 4) joined by h tubes: χ = 4 − 2h
        assert_eq!(euler(&t.mesh), 4 - 2 * h as i64);
        assert_eq!(Topology::new(&t.mesh).connected_components().1, 1);
    }
}

#[test]
fn topology_on_a_convex_shape_is_a_clear_error() {
    let e = transform(&synth::icosphere(4, 1.0), Kind::Topology, 1, 0).unwrap_err();
    assert!(matches!(
        e,
        BenchError::NothingToWeld {
            needed: 2,
            found: 0
        }
    ));
    assert!(e.to_string().contains("convex"));
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
    #[test]
    fn any_kind_strength_and_seed_gives_a_valid_map(
        k in 0usize..8, s in 1u8..=5, seed in proptest::prelude::any::<u64>()
    ) {
        let kind = Kind::ALL[k];
        let null = if kind == Kind::Topology { two_spheres(0.03) } else { synth::protrusion_sphere(3, 0.8, 0.25) };
        check(&null, kind, s, seed);
    }
}
