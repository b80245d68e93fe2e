//! Descriptor properties on synthetic and real meshes.

use std::path::{Path, PathBuf};

use keycomp_components::{DetectParams, detect};
use keycomp_describe::{DIM, describe, distance};
use keycomp_mesh::{Mesh, Vector3, geometry, read_mesh, synth};
use nalgebra::{Rotation3, Unit};

#[test]
fn histograms_sum_to_one_and_layout_is_symmetric() {
    let mesh = synth::textured_protrusion_sphere(6);
    let det = detect(&mesh, &DetectParams::default()).expect("detect");
    let d = describe(&mesh, &det).expect("describe");
    assert_eq!(d.components.len(), det.components.len());
    for c in &d.components {
        for (lo, hi) in [(0, 8), (8, 16), (16, 24), (24, 28)] {
            let s: f32 = c.descriptor[lo..hi].iter().sum();
            assert!((s - 1.0).abs() < 1e-4, "bins {lo}..{hi} sum to {s}");
        }
        assert!(c.descriptor.iter().all(|x| x.is_finite() && *x >= 0.0));
        assert!(c.radius > 0.0);
    }
    let m = d.components.len();
    for i in 0..m {
        assert_eq!(d.layout_distance(i, i), 0.0);
        for j in 0..m {
            assert_eq!(d.layout_distance(i, j), d.layout_distance(j, i));
            if i != j {
                assert!(d.layout_distance(i, j) > 0.0);
            }
        }
    }
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
        // the same component (same centre vertex) has nearly the same descriptor
        let cb = b
            .components
            .iter()
            .find(|c| c.center == ca.center)
            .expect("same centre after the motion");
        let d = distance(&ca.descriptor, &cb.descriptor);
        assert!(d < 1e-3, "descriptor moved by {d}");
    }
}

fn shared_data() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    if p.is_dir() {
        Some(p)
    } else {
        eprintln!("skipping: ../shared/data not found");
        None
    }
}

/// Corresponding components (same region of cat0 in another pose, found by area IoU > 0.5
/// through the shared vertex numbering) must be closer in descriptor space than
/// non-corresponding ones.
#[test]
fn corresponding_components_are_closer_than_others_on_tosca_cats() {
    let Some(data) = shared_data() else { return };
    let p = DetectParams::default();
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
