//! Descriptor properties on synthetic and real meshes.

use keycomp_components::{DetectParams, detect};
use keycomp_describe::{
    DIM, DescribeParams, HISTOGRAMS, NO_DISTANCE, SIZE_WEIGHT, Units, describe, describe_with,
    distance,
};
use keycomp_mesh::{Mesh, Vector3, geometry, read_mesh, synth};
use keycomp_test_support::shared_data;
use nalgebra::{Rotation3, Unit};

#[test]
fn histograms_sum_to_one_and_layout_is_symmetric() {
    let mesh = synth::textured_protrusion_sphere(6);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    let d = describe(&mesh, &det).expect("describe");
    let params = DescribeParams::default();
    let k = det.components.len();
    let whole = params.levels.len() as u8 + 1;
    // key-components first, in detection order, then patches by level, then the whole surface
    assert!(d.components.len() > k + params.levels.len());
    for (i, c) in d.components.iter().enumerate() {
        if i < k {
            assert_eq!((c.level, c.center), (0, det.components[i].center));
        }
    }
    assert!(d.components.windows(2).all(|w| w[0].level <= w[1].level));
    let last = d.components.last().expect("parts");
    assert_eq!(last.level, whole);
    assert!((last.area - 1.0).abs() < 1e-9);
    // the histograms cover every entry but the four scalars
    assert_eq!(
        HISTOGRAMS.iter().map(|(a, b)| b - a).sum::<usize>(),
        DIM - 4
    );
    for c in &d.components {
        for (lo, hi) in HISTOGRAMS {
            let s: f32 = c.descriptor[lo..hi].iter().sum();
            assert!((s - 1.0).abs() < 1e-4, "bins {lo}..{hi} sum to {s}");
        }
        assert!(c.descriptor.iter().all(|x| x.is_finite()));
        // every entry but 28 (log of radius over the disc's, negative where the surface
        // gathers more area than a flat disc) is non-negative
        assert!(
            c.descriptor
                .iter()
                .enumerate()
                .all(|(i, x)| i == 28 || *x >= 0.0)
        );
        assert!(c.radius > 0.0);
        if (1..whole).contains(&c.level) {
            // a patch reaches no farther than its level's radius
            assert!(c.radius <= params.levels[c.level as usize - 1] + 1e-9);
        }
    }
    let m = d.components.len();
    for i in 0..m {
        assert_eq!(d.layout_distance(i, i), 0.0);
        for j in 0..m {
            assert_eq!(d.layout_distance(i, j), d.layout_distance(j, i));
            let (a, b) = (&d.components[i], &d.components[j]);
            if a.level == whole || b.level == whole {
                if i != j {
                    assert_eq!(d.layout_distance(i, j), NO_DISTANCE);
                }
            } else if a.center != b.center {
                assert!(d.layout_distance(i, j) > 0.0);
            }
        }
    }
}

#[test]
fn a_shape_without_keypoints_still_gets_parts() {
    let mesh = synth::textured_protrusion_sphere(6);
    let mut det = detect(&mesh, &DetectParams::default()).expect("detect");
    det.components.clear();
    det.keypoints.clear();
    let d = describe(&mesh, &det).expect("describe");
    let params = DescribeParams::default();
    // every level has at least one patch (centres by farthest-point sampling), plus the whole
    for level in 1..=params.levels.len() as u8 + 1 {
        assert!(
            d.components.iter().any(|c| c.level == level),
            "no part at level {level}"
        );
    }
}

#[test]
fn file_units_equal_scale_free_when_the_unit_is_the_shapes_own_size() {
    let mesh = synth::textured_protrusion_sphere(6);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    let free = describe(&mesh, &det).expect("describe");
    let length = geometry::total_area(&mesh).sqrt();
    let units = DescribeParams {
        units: Units::File { length },
        ..DescribeParams::default()
    };
    let file = describe_with(&mesh, &det, &units).expect("describe");
    assert_eq!(free.components.len(), file.components.len());
    for (a, b) in free.components.iter().zip(&file.components) {
        assert_eq!((a.center, a.level), (b.center, b.level));
        // every entry but 31 (keypoint density scale-free, size in file units) agrees
        let (mut x, mut y) = (a.descriptor, b.descriptor);
        (x[31], y[31]) = (0.0, 0.0);
        assert!(distance(&x, &y) < 1e-3);
        let size = SIZE_WEIGHT * (b.radius as f32).ln();
        assert!((b.descriptor[31] - size).abs() < 1e-4);
    }
    // a unit twice as long: patches of the same level cover four times the relative area
    let twice = DescribeParams {
        units: Units::File {
            length: 2.0 * length,
        },
        ..DescribeParams::default()
    };
    let big = describe_with(&mesh, &det, &twice).expect("describe");
    let first = |d: &keycomp_describe::ShapeDescription| {
        d.components
            .iter()
            .find(|c| c.level == 1)
            .map(|c| c.area)
            .expect("a level-1 patch")
    };
    assert!(first(&big) > 2.0 * first(&free));
    assert!(
        describe_with(
            &mesh,
            &det,
            &DescribeParams {
                units: Units::File { length: 0.0 },
                ..DescribeParams::default()
            }
        )
        .is_err()
    );
}

#[test]
fn descriptors_are_invariant_to_rigid_motion_and_scale() {
    let mesh = synth::textured_protrusion_sphere(6);
    let p = DetectParams::default();
    let a = describe(&mesh, &detect(&mesh, &p).expect("detect")).expect("describe");
    let rot = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 2.0, -0.5)), 0.7);
    let moved = Mesh {
        positions: mesh
            .positions
            .iter()
            .map(|&q| rot * (q * 250.0) + Vector3::new(3.0, -9.0, 40.0))
            .collect(),
        faces: mesh.faces.clone(),
    };
    let b = describe(&moved, &detect(&moved, &p).expect("detect")).expect("describe");
    assert_eq!(a.components.len(), b.components.len());
    for ca in &a.components {
        // the same part (same centre vertex and level) has nearly the same descriptor
        let cb = b
            .components
            .iter()
            .find(|c| c.center == ca.center && c.level == ca.level)
            .expect("same centre after the motion");
        let d = distance(&ca.descriptor, &cb.descriptor);
        assert!(d < 1e-3, "descriptor moved by {d}");
    }
}

/// Corresponding components (same region of cat0 in another pose, found by area IoU > 0.5
/// through the shared vertex numbering) must be closer in descriptor space than
/// non-corresponding ones.
#[test]
fn corresponding_components_are_closer_than_others_on_tosca_cats() {
    let Some(data) = shared_data("") else { return };
    // geodesics on the meshes themselves (the paper's), so that which components correspond
    // does not hang on the speed options of detection: this is a property of the descriptors
    let p = DetectParams {
        geodesic: keycomp_components::GeodesicOptions {
            proxy_vertices: 0,
            ..Default::default()
        },
        ..DetectParams::default()
    };
    let null = read_mesh(&data.join("tosca/cat0.off")).expect("cat0").mesh;
    let areas = geometry::vertex_areas(&null);
    let dn = detect(&null, &p).expect("detect");
    let desc_n = describe(&null, &dn).expect("describe");
    let (mut same, mut other) = (Vec::new(), Vec::new());
    for pose in [1, 3, 5, 7, 9] {
        let m = read_mesh(&data.join(format!("tosca/cat{pose}.off")))
            .expect("pose")
            .mesh;
        let dp = detect(&m, &p).expect("detect");
        let desc_p = describe(&m, &dp).expect("describe");
        for (ci, c) in dp.components.iter().enumerate() {
            for (ni, nc) in dn.components.iter().enumerate() {
                let iou = keycomp_bench::overlap(&areas, &c.vertices, &nc.vertices);
                let d = distance(
                    &desc_p.components[ci].descriptor,
                    &desc_n.components[ni].descriptor,
                );
                if iou > 0.5 {
                    same.push(d);
                } else if iou < 0.05 {
                    other.push(d);
                }
            }
        }
    }
    let med = |v: &mut Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    assert!(!same.is_empty() && !other.is_empty());
    let (ms, mo) = (med(&mut same), med(&mut other));
    println!(
        "descriptor distance (DIM {DIM}): corresponding median {ms:.4} (n={}), non-corresponding median {mo:.4} (n={})",
        same.len(),
        other.len()
    );
    assert!(
        ms < 0.5 * mo,
        "corresponding {ms} vs non-corresponding {mo}"
    );
}

#[test]
fn complete_only_leaves_out_parts_that_reach_the_boundary() {
    // a bumpy open sheet: patches near its rim reach the boundary
    let mesh = synth::height_field(40, 40, 0.05, |x, y| 0.1 * (6.0 * x).sin() * (5.0 * y).cos());
    let topo = keycomp_mesh::Topology::new(&mesh);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    let all = describe(&mesh, &det).expect("describe");
    let only_complete = DescribeParams {
        complete_only: true,
        ..DescribeParams::default()
    };
    let complete = describe_with(&mesh, &det, &only_complete).expect("describe");
    let touches = |c: &keycomp_describe::ComponentDescription| {
        c.vertices.iter().any(|&v| topo.is_boundary(v))
    };
    assert!(all.components.iter().any(touches));
    assert!(!complete.components.is_empty());
    assert!(!complete.components.iter().any(touches));
    // a part that is nowhere complete: everything reaches the boundary, so all parts are kept
    let tiny = synth::grid(3, 3, 1.0);
    let det = detect(&tiny, &DetectParams::default()).expect("detect");
    let d = describe_with(&tiny, &det, &only_complete).expect("describe");
    assert!(!d.components.is_empty());
}

#[test]
fn out_of_range_parameters_are_refused() {
    let mesh = synth::textured_protrusion_sphere(4);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    for params in [
        DescribeParams {
            patches_per_level: keycomp_describe::MAX_PATCHES_PER_LEVEL + 1,
            ..DescribeParams::default()
        },
        DescribeParams {
            levels: vec![0.1; keycomp_describe::MAX_LEVELS + 1],
            ..DescribeParams::default()
        },
        DescribeParams {
            levels: vec![0.1, f64::NAN],
            ..DescribeParams::default()
        },
        DescribeParams {
            smoothing_iterations: usize::MAX,
            ..DescribeParams::default()
        },
    ] {
        let e = describe_with(&mesh, &det, &params).expect_err("refused");
        assert!(
            e.to_string().starts_with("invalid description parameters"),
            "{e}"
        );
    }
}

#[test]
fn a_fragment_query_gets_patches_of_its_sources_sizes() {
    // a cut that keeps f of the area, scaled to unit area on its own, is magnified by 1/√f:
    // described as a query, its patch radii in the source's unit are the source's again
    let mesh = synth::textured_protrusion_sphere(6);
    let (part, _) =
        keycomp_mesh::cut::cut_by_plane(&mesh, keycomp_mesh::Point3::origin(), Vector3::z());
    let f = geometry::total_area(&part) / geometry::total_area(&mesh);
    assert!((0.4..0.6).contains(&f), "kept {f}");
    let defaults = DescribeParams::default();
    // closed: described as indexed; a fragment in file units keeps its source's scale
    assert_eq!(defaults.for_query(&mesh), vec![defaults.clone()]);
    let file = DescribeParams {
        units: Units::File { length: 1.0 },
        ..DescribeParams::default()
    };
    assert_eq!(file.for_query(&part), vec![file.clone()]);
    let hypotheses = defaults.for_query(&part);
    assert_eq!(hypotheses.len(), 2);
    // in the source's unit, one hypothesis has every radius within the ladder's half step of
    // the source's; the indexed description has none
    let in_source = |r: f64| r * f.sqrt();
    let within = |levels: &[f64]| {
        levels
            .iter()
            .zip(&defaults.levels)
            .all(|(q, s)| (in_source(*q) / s).ln().abs() < 0.5 * 1.5f64.ln())
    };
    assert!(!within(&defaults.levels));
    let query = hypotheses
        .iter()
        .find(|h| within(&h.levels))
        .expect("a hypothesis at the fragment's scale");
    assert_eq!(query.levels.len(), defaults.levels.len());
    // and the parts' measured radii follow: the largest patch of the middle level
    let det = detect(&part, &DetectParams::default()).expect("detect");
    let d = describe_with(&part, &det, query).expect("describe");
    let level = 3u8;
    let widest = d
        .components
        .iter()
        .filter(|c| c.level == level)
        .map(|c| c.radius)
        .fold(0.0, f64::max);
    let want = query.levels[usize::from(level) - 1];
    assert!(
        widest <= want * 1.0001 && widest > 0.8 * want,
        "{widest} for {want}"
    );
}

#[test]
fn describing_under_several_parameters_equals_describing_under_each() {
    // the ladders share the surface and its fronts; other parameters are described apart
    let mesh = synth::textured_protrusion_sphere(5);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    let base = DescribeParams::default();
    let all = vec![
        base.clone(),
        DescribeParams {
            levels: vec![0.1, 0.3],
            ..base.clone()
        },
        DescribeParams {
            smoothing_iterations: 5,
            ..base.clone()
        },
    ];
    let together = keycomp_describe::describe_all(&mesh, &det, &all).expect("describe");
    assert_eq!(together.len(), all.len());
    for (d, params) in together.iter().zip(&all) {
        assert_eq!(d, &describe_with(&mesh, &det, params).expect("describe"));
    }
    assert!(
        keycomp_describe::describe_all(&mesh, &det, &[])
            .expect("nothing")
            .is_empty()
    );
}

#[test]
fn descriptions_do_not_depend_on_the_thread_count() {
    // the levels and the fronts run in parallel; with fronts stopped at a reach, a centre
    // shared by two levels is asked for at two reaches, in whatever order the threads come
    let mesh = synth::textured_protrusion_sphere(5);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    let reach = DescribeParams {
        layout_reach: Some(0.2),
        ..DescribeParams::default()
    };
    for params in [DescribeParams::default(), reach] {
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| describe_with(&mesh, &det, &params).expect("describe"))
        };
        let one = on(1);
        for threads in [2, 3, 4] {
            assert_eq!(one, on(threads), "{threads} threads");
        }
    }
}

#[test]
fn a_large_mesh_is_described_on_its_proxy_and_lifted_back() {
    let mesh = synth::textured_protrusion_sphere(6);
    let n = mesh.num_vertices();
    let detect_params = DetectParams::default();
    let params = DescribeParams {
        proxy_vertices: detect_params.geodesic.proxy_vertices,
        ..DescribeParams::default()
    };
    assert!(n > params.proxy_vertices);
    let det = detect(&mesh, &detect_params).expect("detect");
    assert!(
        det.proxy.is_some(),
        "detection kept the proxy its fronts ran on"
    );
    let d = describe_with(&mesh, &det, &params).expect("describe");
    // a detection without its proxy (as from a cache) gets the same simplification made anew
    let mut bare = det.clone();
    bare.proxy = None;
    assert_eq!(describe_with(&mesh, &bare, &params).expect("describe"), d);

    let areas = geometry::vertex_areas(&mesh);
    let total: f64 = areas.iter().sum();
    let whole = params.levels.len() as u8 + 1;
    for (i, c) in d.components.iter().enumerate() {
        assert!(
            c.vertices.windows(2).all(|w| w[0] < w[1]),
            "sorted, distinct"
        );
        assert!(c.vertices.iter().all(|&v| (v as usize) < n));
        assert!(
            c.vertices.binary_search(&c.center).is_ok(),
            "part {i} holds its centre"
        );
        match c.level {
            0 => assert_eq!(c.vertices, det.components[i].vertices),
            l if l == whole => assert_eq!(c.vertices.len(), n),
            _ => {
                // the lifted vertices cover what the part covered on the proxy
                let lifted: f64 =
                    c.vertices.iter().map(|&v| areas[v as usize]).sum::<f64>() / total;
                assert!(
                    (lifted - c.area).abs() < 0.01 + 0.1 * c.area,
                    "part {i}: {lifted} of the input's area, {} of the proxy's",
                    c.area
                );
            }
        }
    }
    // described on its own vertices (the default), the same shape gets parts of the same sizes
    let full = describe(&mesh, &det).expect("describe");
    let median_area = |d: &keycomp_describe::ShapeDescription, level: u8| {
        let mut a: Vec<f64> = d
            .components
            .iter()
            .filter(|c| c.level == level)
            .map(|c| c.area)
            .collect();
        a.sort_by(f64::total_cmp);
        a[a.len() / 2]
    };
    for level in 1..whole {
        let (p, f) = (median_area(&d, level), median_area(&full, level));
        assert!(
            (p - f).abs() < 0.1 * f,
            "level {level}: {p} on the proxy, {f} on the mesh"
        );
    }
}
