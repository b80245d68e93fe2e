//! End-to-end: the same surface in OFF and in glTF (GLB) gives the same keypoints and
//! key-components, vertex for vertex.

mod common;

use keycomp_mesh::{Mesh, Point3, synth, write_glb, write_off};
use serde_json::Value;

use common::{keycomp, s, stderr};

/// `keycomp CMD FILE --json` with the fields that name the file or time the run removed.
fn json_of(args: &[&str]) -> Value {
    let o = keycomp(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    let mut v: Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let obj = v.as_object_mut().expect("object");
    obj.remove("mesh");
    obj.remove("timings_ms");
    v
}

#[test]
fn a_glb_gives_the_keypoints_and_components_of_the_same_off() {
    let dir = tempfile::tempdir().expect("tempdir");
    // GLB stores f32 coordinates: the OFF gets the same values.
    let m = synth::textured_protrusion_sphere(5);
    let m = Mesh {
        positions: m
            .positions
            .iter()
            .map(|p| {
                Point3::new(
                    f64::from(p.x as f32),
                    f64::from(p.y as f32),
                    f64::from(p.z as f32),
                )
            })
            .collect(),
        faces: m.faces,
    };
    let off = dir.path().join("shape.off");
    let glb = dir.path().join("shape.glb");
    write_off(&m, &off).expect("OFF");
    write_glb(&m, &glb).expect("GLB");
    for cmd in ["keypoints", "detect"] {
        let a = json_of(&[cmd, s(&off), "--json"]);
        let b = json_of(&[cmd, s(&glb), "--json"]);
        assert_eq!(a, b, "{cmd}");
    }
    let keypoints = json_of(&["keypoints", s(&glb), "--json"]);
    assert!(!keypoints["keypoints"].as_array().expect("array").is_empty());
}
