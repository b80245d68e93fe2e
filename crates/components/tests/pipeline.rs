//! Key-component detection end to end on synthetic and real meshes.

use std::path::Path;

use keycomp_components::{DetectParams, Detection, GeodesicOptions, detect, keypoint_distances};
use keycomp_mesh::{Mesh, Point3, Topology, Vector3, geometry, read_mesh, synth};
use keycomp_test_support::shared_data;
use nalgebra::{Rotation3, Unit};

/// Area-weighted intersection over union of two vertex sets (barycentric vertex areas).
fn area_iou(areas: &[f64], a: &[u32], b: &[u32]) -> f64 {
    let mut in_a = vec![false; areas.len()];
    for &v in a {
        in_a[v as usize] = true;
    }
    let (mut inter, mut union) = (0.0, 0.0);
    for &v in a {
        union += areas[v as usize];
    }
    for &v in b {
        if in_a[v as usize] {
            inter += areas[v as usize];
        } else {
            union += areas[v as usize];
        }
    }
    if union > 0.0 { inter / union } else { 0.0 }
}

/// For each component of `b`, its best area IoU with a component of `a` (areas of `a`'s mesh).
fn best_ious(areas: &[f64], a: &Detection, b: &Detection) -> Vec<f64> {
    b.components
        .iter()
        .map(|cb| {
            a.components
                .iter()
                .map(|ca| area_iou(areas, &ca.vertices, &cb.vertices))
                .fold(0.0, f64::max)
        })
        .collect()
}

fn is_connected(topo: &Topology, vertices: &[u32]) -> bool {
    let set: std::collections::HashSet<u32> = vertices.iter().copied().collect();
    let mut seen = std::collections::HashSet::new();
    let mut stack = vec![vertices[0]];
    seen.insert(vertices[0]);
    while let Some(v) = stack.pop() {
        for &w in topo.neighbors(v) {
            if set.contains(&w) && seen.insert(w) {
                stack.push(w);
            }
        }
    }
    seen.len() == set.len()
}

/// Detection parameters with the fronts on the full mesh (`proxy` = 0) or on a proxy.
fn with_proxy(proxy: usize) -> DetectParams {
    DetectParams {
        geodesic: GeodesicOptions {
            proxy_vertices: proxy,
            ..GeodesicOptions::full_mesh()
        },
        ..DetectParams::default()
    }
}

#[test]
fn textured_protrusions_give_one_connected_component_each() {
    // the full mesh (the paper's method), the default, and a proxy of a quarter of the vertices
    for params in [with_proxy(0), DetectParams::default(), with_proxy(10_000)] {
        protrusions_give_one_component_each(&params);
    }
}

fn protrusions_give_one_component_each(params: &DetectParams) {
    let mesh = synth::textured_protrusion_sphere(6);
    let topo = Topology::new(&mesh);
    let det = detect(&mesh, params).expect("detect");
    let proxy = params.geodesic.proxy_vertices;
    if proxy == 0 {
        assert_eq!(det.geodesic_vertices, mesh.num_vertices());
    } else {
        assert!(det.geodesic_vertices <= proxy.max(det.keypoints.len()));
        assert!(det.timings.simplify > 0.0 && det.timings.simplify <= det.timings.geodesic);
    }
    let n = synth::protrusion_directions().len();
    assert_eq!(det.components.len(), n, "one per protrusion");
    let mut tip_hit = vec![false; n];
    for c in &det.components {
        assert!(c.keypoints.len() >= 30, "KC-1 needs N = 30 keypoints");
        assert!(
            c.missed_keypoints.is_empty(),
            "component {} missed keypoints",
            c.id
        );
        for k in &c.keypoints {
            assert!(
                c.vertices.binary_search(k).is_ok(),
                "keypoint {k} not in component"
            );
        }
        assert!(
            is_connected(&topo, &c.vertices),
            "component {} in pieces",
            c.id
        );
        assert!(c.area > 0.0 && c.area < 0.5);
        // the component's centre is on a protrusion: within the bump's angular width (0.35 rad)
        // of the nearest protrusion direction, each protrusion once
        let u = mesh.positions[c.center as usize].coords.normalize();
        let (nearest, angle) = synth::protrusion_directions()
            .iter()
            .enumerate()
            .map(|(i, d)| (i, u.dot(d).clamp(-1.0, 1.0).acos()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("directions");
        assert!(
            angle < 0.35,
            "component {} centre {angle} rad off its protrusion",
            c.id
        );
        assert!(!tip_hit[nearest], "two components on protrusion {nearest}");
        tip_hit[nearest] = true;
    }
}

#[test]
fn detection_is_deterministic() {
    let mesh = synth::textured_protrusion_sphere(5);
    for p in [with_proxy(0), with_proxy(3000)] {
        let a = detect(&mesh, &p).expect("detect");
        let b = detect(&mesh, &p).expect("detect");
        assert_eq!(a.keypoints, b.keypoints);
        assert_eq!(a.components, b.components);
        assert_eq!(a.embedding.points, b.embedding.points);
    }
}

/// Mean and max relative difference of `a` from `b` over the pairs i < j of a K×K matrix.
fn relative_difference(a: &[f64], b: &[f64], k: usize) -> (f64, f64) {
    let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0);
    for i in 0..k {
        for j in i + 1..k {
            let r = (a[i * k + j] - b[i * k + j]).abs() / b[i * k + j];
            sum += r;
            max = max.max(r);
            n += 1;
        }
    }
    (sum / n as f64, max)
}

#[test]
fn proxy_distances_stay_close_to_the_full_mesh_and_to_great_circles() {
    // a unit sphere of 40,962 vertices, 1 % of them as keypoints spread over it
    let mesh = synth::icosphere(6, 1.0);
    let topo = Topology::new(&mesh);
    let keypoints: Vec<u32> = (0..mesh.num_vertices() as u32).step_by(100).collect();
    let k = keypoints.len();
    let unit: Vec<Vector3<f64>> = keypoints
        .iter()
        .map(|&a| mesh.positions[a as usize].coords.normalize())
        .collect();
    let exact: Vec<f64> = unit
        .iter()
        .flat_map(|pa| unit.iter().map(|pb| pa.dot(pb).clamp(-1.0, 1.0).acos()))
        .collect();
    let full = GeodesicOptions::full_mesh();
    let (d_full, n_full, t_full) = keypoint_distances(&mesh, &topo, &keypoints, &full).unwrap();
    assert_eq!((n_full, t_full), (mesh.num_vertices(), 0.0));
    let (err_full, _) = relative_difference(d_full.as_slice(), &exact, k);
    // bounds: 1 % for the method at 20k vertices (the full mesh gives 0.49 %); a proxy of a
    // quarter of the vertices gives 1.07 %, in one cell or in four (simplified in parallel)
    for (proxy, cells, count, bound) in [
        (20_000, 0, 1, 0.01),
        (10_000, 0, 1, 0.015),
        (10_000, 10_000, 4, 0.015),
    ] {
        let options = GeodesicOptions {
            proxy_vertices: proxy,
            proxy_cell_vertices: cells,
            ..full
        };
        assert_eq!(options.proxy_cells(mesh.num_vertices()), count);
        let (d, n, _) = keypoint_distances(&mesh, &topo, &keypoints, &options).unwrap();
        assert_eq!(n, proxy);
        let (vs_full, vs_full_max) = relative_difference(d.as_slice(), d_full.as_slice(), k);
        let (err, err_max) = relative_difference(d.as_slice(), &exact, k);
        println!(
            "proxy {proxy} in cells of {cells}: vs full mesh mean {:.3} % (max {:.2} %); vs \
             great circles {:.3} % (max {:.2} %), full mesh {:.3} %",
            100.0 * vs_full,
            100.0 * vs_full_max,
            100.0 * err,
            100.0 * err_max,
            100.0 * err_full
        );
        assert!(
            err < bound,
            "proxy {proxy}: mean error vs great circles {err}"
        );
        assert!(vs_full < bound, "proxy {proxy}: mean difference {vs_full}");
        assert!(err_full < err, "the full mesh is the more accurate");
    }
    // no proxy when the mesh is already small enough
    let big = GeodesicOptions {
        proxy_vertices: 50_000,
        ..full
    };
    let (d, n, t) = keypoint_distances(&mesh, &topo, &keypoints, &big).unwrap();
    assert_eq!((n, t), (mesh.num_vertices(), 0.0));
    assert_eq!(d, d_full);
}

#[test]
fn geodesic_options_are_validated_and_default_in_json() {
    let mesh = synth::icosphere(3, 1.0);
    for (proxy, angle) in [(50, 90.0), (1, 90.0), (0, 89.0), (0, 181.0), (0, f64::NAN)] {
        let mut p = with_proxy(proxy);
        p.geodesic.min_split_angle_degrees = angle;
        let e = detect(&mesh, &p).unwrap_err().to_string();
        assert!(e.contains("geodesic."), "{e}");
    }
    for (proxy, angle) in [(0, 90.0), (100, 120.0), (100_000, 180.0)] {
        let mut p = with_proxy(proxy);
        p.geodesic.min_split_angle_degrees = angle;
        p.validate().unwrap();
    }
    for (cells, ok) in [
        (0, true),
        (1, false),
        (999, false),
        (1000, true),
        (usize::MAX, true),
    ] {
        let mut p = DetectParams::default();
        p.geodesic.proxy_cell_vertices = cells;
        assert_eq!(detect(&mesh, &p).is_ok(), ok, "cells of {cells}");
    }
    // a configuration without the field reads as the default
    let old: DetectParams = serde_json::from_str(r#"{"components": {"sigma": 1.2}}"#).unwrap();
    assert_eq!(old.geodesic, GeodesicOptions::default());
    let json = serde_json::to_string(&DetectParams::default()).unwrap();
    assert!(json.contains(r#""geodesic":{"proxy_vertices":"#), "{json}");
}

#[test]
fn rigid_motion_and_uniform_scale_give_the_same_components() {
    let mesh = synth::textured_protrusion_sphere(6);
    let params = DetectParams::default();
    let base = detect(&mesh, &params).expect("detect");
    let areas = geometry::vertex_areas(&mesh);
    let rot = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(0.3, -1.0, 0.7)), 1.1);
    for (name, f) in [
        (
            "rotation+translation",
            Box::new(move |p: Point3<f64>| rot * p + Vector3::new(100.0, -50.0, 7.0))
                as Box<dyn Fn(Point3<f64>) -> Point3<f64>>,
        ),
        ("scale ×1000", Box::new(|p: Point3<f64>| p * 1000.0)),
        (
            "scale ×0.001 + rotation",
            Box::new(move |p: Point3<f64>| rot * (p * 0.001)),
        ),
    ] {
        let moved = Mesh {
            positions: mesh.positions.iter().map(|&p| f(p)).collect(),
            faces: mesh.faces.clone(),
        };
        let det = detect(&moved, &params).expect("detect");
        // Rounding differs in the last bits after the motion, so a keypoint tied with the
        // 1 % cut-off could swap and a boundary vertex of a grown region could flip: require
        // the same number of components and each to match one of the original ones almost
        // exactly (area IoU ≥ 0.95).
        assert_eq!(det.components.len(), base.components.len(), "{name}");
        let ious = best_ious(&areas, &base, &det);
        assert!(ious.iter().all(|&o| o >= 0.95), "{name}: {ious:?}");
        let ratio = base.components[0].sphere_radius / det.components[0].sphere_radius;
        println!("{name}: IoUs {ious:?}, radius ratio {ratio}");
    }
}

/// TOSCA poses share vertex numbering, so each pose's components map to cat0 by vertex id.
/// Run with the fronts on the full mesh (the paper's method) and with the default options.
#[test]
fn tosca_cat_poses_repeat_cat0_components() {
    let Some(data) = shared_data("") else { return };
    for params in [with_proxy(0), DetectParams::default()] {
        println!(
            "geodesic options: {:?}{}",
            params.geodesic,
            if params.geodesic == GeodesicOptions::default() {
                " (the default)"
            } else {
                ""
            }
        );
        cat_poses_repeat(&data, &params);
    }
}

fn cat_poses_repeat(data: &Path, params: &DetectParams) {
    let null = read_mesh(&data.join("tosca/cat0.off")).expect("cat0").mesh;
    let areas = geometry::vertex_areas(&null);
    let base = detect(&null, params).expect("detect cat0");
    println!("cat0: {} components", base.components.len());
    // on a real mesh too: every component holds its cluster's keypoints and is one piece
    let topo = Topology::new(&null);
    for c in &base.components {
        assert!(
            c.missed_keypoints.is_empty(),
            "cat0 component {} missed keypoints",
            c.id
        );
        assert!(
            c.keypoints
                .iter()
                .all(|k| c.vertices.binary_search(k).is_ok())
        );
        assert!(
            is_connected(&topo, &c.vertices),
            "cat0 component {} in pieces",
            c.id
        );
    }
    let mut all = Vec::new();
    for pose in 1..=10 {
        let m = read_mesh(&data.join(format!("tosca/cat{pose}.off")))
            .expect("pose")
            .mesh;
        assert_eq!(m.num_vertices(), null.num_vertices());
        let det = detect(&m, params).expect("detect pose");
        let ious = best_ious(&areas, &base, &det);
        let mean = ious.iter().sum::<f64>() / ious.len().max(1) as f64;
        println!(
            "cat{pose}: {} components, best IoU with cat0 {:?}, mean {mean:.3}",
            det.components.len(),
            ious.iter()
                .map(|o| (o * 1000.0).round() / 1000.0)
                .collect::<Vec<_>>()
        );
        all.extend(ious);
    }
    let mean = all.iter().sum::<f64>() / all.len().max(1) as f64;
    let rep = all.iter().filter(|&&o| o > 0.5).count() as f64 / all.len().max(1) as f64;
    println!("all poses: mean best IoU {mean:.3}, repeatability at 0.5: {rep:.3}");
    assert!(!all.is_empty(), "no components on any pose");
    assert!(
        mean > 0.5,
        "components do not repeat across poses: mean IoU {mean}"
    );
}
