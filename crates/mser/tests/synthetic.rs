//! The method on synthetic shapes whose answer is known: every protrusion of a protrusion
//! sphere is a maximally stable component, the MSER key-components are one per protrusion, and
//! scaling the shape changes nothing.

use keycomp_mesh::{Mesh, Point3, synth};
use keycomp_mser::{MserParams, Output, Weighting, detect};

fn tips_inside(set: &[u32], tips: &[u32]) -> Vec<usize> {
    (0..tips.len())
        .filter(|&i| set.binary_search(&tips[i]).is_ok())
        .collect()
}

#[test]
fn each_protrusion_is_a_stable_component_and_a_key_component() {
    let mesh = synth::protrusion_sphere(4, 0.8, 0.25);
    let tips = synth::protrusion_tips(&mesh);
    for weighting in [Weighting::Edge, Weighting::Vertex] {
        let params = MserParams {
            weighting,
            ..MserParams::default()
        };
        let det = detect(&mesh, &params).unwrap();
        assert_eq!(det.keypoints.len(), 6, "{weighting}");
        // every tip lies in a stable component holding no other tip
        for (i, &tip) in tips.iter().enumerate() {
            assert!(
                det.components
                    .iter()
                    .any(|c| tips_inside(c, &tips) == vec![i] && c.binary_search(&tip).is_ok()),
                "{weighting}: protrusion {i} is not a stable component of its own"
            );
        }
        // the covering set: six disjoint components, one tip each
        let kc = det.selected(Output::KeyComponents);
        assert_eq!(kc.len(), 6, "{weighting}");
        let mut seen = [false; 6];
        for c in &kc {
            let inside = tips_inside(c, &tips);
            assert_eq!(inside.len(), 1, "{weighting}");
            seen[inside[0]] = true;
        }
        assert!(seen.iter().all(|&s| s));
        for (a, x) in kc.iter().enumerate() {
            for y in &kc[a + 1..] {
                assert!(x.iter().all(|v| y.binary_search(v).is_err()), "disjoint");
            }
        }
        assert!(det.uncovered.is_empty());
    }
}

#[test]
fn scaling_the_shape_gives_the_same_components() {
    let mesh = synth::protrusion_sphere(4, 0.8, 0.25);
    let scaled = Mesh {
        positions: mesh
            .positions
            .iter()
            .map(|p| Point3::from(p.coords * 7.5))
            .collect(),
        faces: mesh.faces.clone(),
    };
    let p = MserParams::default();
    let a = detect(&mesh, &p).unwrap();
    let b = detect(&scaled, &p).unwrap();
    assert_eq!(a.keypoints, b.keypoints);
    assert_eq!(
        a.selected(Output::KeyComponents),
        b.selected(Output::KeyComponents)
    );
    let da = a.to_detection(&mesh, Output::KeyComponents).unwrap();
    let db = b.to_detection(&scaled, Output::KeyComponents).unwrap();
    for (x, y) in da.components.iter().zip(&db.components) {
        assert!((x.area - y.area).abs() < 1e-12);
        assert!((y.sphere_radius / x.sphere_radius - 7.5).abs() < 1e-9);
    }
    assert!((db.area / da.area - 7.5 * 7.5).abs() < 1e-6);
}

#[test]
fn bad_parameters_and_foreign_meshes_are_errors() {
    let mesh = synth::icosphere(2, 1.0);
    for p in [
        MserParams {
            time: 0.0,
            ..MserParams::default()
        },
        MserParams {
            eigenpairs: 1,
            ..MserParams::default()
        },
        MserParams {
            keypoint_time: f64::NAN,
            ..MserParams::default()
        },
    ] {
        assert!(detect(&mesh, &p).is_err());
    }
    let det = detect(&mesh, &MserParams::default()).unwrap();
    let other = synth::icosphere(1, 1.0);
    assert!(det.to_detection(&other, Output::All).is_err());
}
