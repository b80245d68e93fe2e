//! End-to-end tests of the comparison method of Section 4.4 (diffusion-geometric MSER and MSER
//! key-components): `keycomp detect --method mser|mser-kc` on a synthetic file, and the
//! repeatability of MSER key-components across real TOSCA poses.

mod common;

use keycomp_bench::{best_overlaps, repeatability};
use keycomp_mesh::geometry::vertex_areas;
use keycomp_mesh::{read_mesh, synth, write_off};
use keycomp_mser::{MserParams, Output, detect};
use keycomp_test_support::shared_data;
use serde_json::Value;

use common::{keycomp, s, stderr, stdout};

fn ids(v: &Value) -> Vec<u32> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_u64().expect("id") as u32)
        .collect()
}

#[test]
fn detect_mser_kc_json_gives_one_component_per_protrusion() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mesh = synth::protrusion_sphere(4, 0.8, 0.25);
    let path = dir.path().join("proto.off");
    write_off(&mesh, &path).expect("write OFF");
    let tips = synth::protrusion_tips(&mesh);

    // on the mesh as read: its tips' vertex ids are the oracle
    let o = keycomp(&[
        "detect",
        s(&path),
        "--method",
        "mser-kc",
        "--json",
        "--surface",
        "as-read",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(j["method"], "mser-kc");
    assert_eq!(j["vertices"], mesh.num_vertices());
    assert_eq!(
        ids(&j["keypoints"]).len(),
        6,
        "one HKS keypoint per protrusion"
    );
    let comps = j["components"].as_array().expect("components");
    assert_eq!(comps.len(), 6);
    let mut seen = [false; 6];
    for c in comps {
        let verts = ids(&c["vertices"]);
        let inside: Vec<usize> = (0..6)
            .filter(|&i| verts.binary_search(&tips[i]).is_ok())
            .collect();
        assert_eq!(
            inside.len(),
            1,
            "each component holds exactly one tip: {inside:?}"
        );
        seen[inside[0]] = true;
        assert_eq!(ids(&c["keypoints"]).len(), 1);
        let area = c["area"].as_f64().expect("area");
        assert!(area > 0.005 && area < 0.2, "area {area}");
        assert!(c["sphere"]["radius"].as_f64().expect("radius") > 0.0);
    }
    assert!(seen.iter().all(|&x| x), "every protrusion is covered");
    // the same JSON shape as key-components, plus the MSER stages' timings
    let t = &j["timings_ms"];
    for key in [
        "read", "harris", "geodesic", "mds", "cluster", "extract", "total",
    ] {
        assert!(t[key].is_number(), "timings_ms.{key} missing: {t}");
    }
    assert!(t["spectrum"].as_f64().expect("spectrum") > 0.0);
    assert!(t["mser"].is_number());
    assert_eq!(j["mser_params"]["weighting"], "edge");

    // all maximally stable components: at least the covering set
    let o = keycomp(&["detect", s(&path), "--method", "mser", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let all: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert!(all["components"].as_array().expect("components").len() >= 6);

    // key-components stay the default, without the MSER timings
    let o = keycomp(&["detect", s(&path), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let kc: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(kc["method"], "kc");
    assert!(kc["timings_ms"].get("spectrum").is_none());

    // text output names the method
    let o = keycomp(&["detect", s(&path), "--method", "mser-kc"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("method mser-kc"), "{}", stdout(&o));
}

#[test]
fn bad_method_and_bad_file_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("proto.off");
    write_off(&synth::icosphere(2, 1.0), &path).expect("write OFF");
    let o = keycomp(&["detect", s(&path), "--method", "sift"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("kc, mser or mser-kc"), "{}", stderr(&o));
    let bad = dir.path().join("bad.off");
    std::fs::write(&bad, "OFF\n3 1 0\n0 0 0\n1 0 0\n").expect("write");
    let o = keycomp(&["detect", s(&bad), "--method", "mser-kc"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("bad.off"), "{}", stderr(&o));
}

#[test]
fn bench_repeatability_prints_tables_5_and_6() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).expect("mkdir");
    write_off(&synth::protrusion_sphere(4, 0.8, 0.25), &data.join("p.off")).expect("write");
    let out = dir.path().join("out");
    let o = keycomp(&[
        "bench",
        "repeatability",
        "--data",
        s(&data),
        "--method",
        "mser,mser-kc",
        "--kinds",
        "scale,noise",
        "--strengths",
        "1",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = stdout(&o);
    assert!(md.contains("### MSER (edge weights"), "{md}");
    assert!(md.contains("Sipiran & Bustos 2013, Table 5"), "{md}");
    assert!(md.contains("Sipiran & Bustos 2013, Table 6"), "{md}");
    // scale: the same components, ours 1.00 beside the paper's 0.81 / 0.76
    assert!(md.contains("| Scale | 1.00 / 0.81"), "{md}");
    assert!(md.contains("| Scale | 1.00 / 0.76"), "{md}");
    assert!(
        !md.contains("KC-1"),
        "no key-component preset unless asked: {md}"
    );
    let results: Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).expect("results"))
            .expect("JSON");
    let presets = results["presets"].as_array().expect("presets");
    assert_eq!(presets.len(), 2);
    assert_eq!(presets[1]["preset"]["name"], "MSER-KC");
    assert_eq!(presets[1]["preset"]["method"], "mser-kc");
    assert_eq!(results["mser"]["eigenpairs"], 60);
    assert!(out.join("repeatability-mserkc.svg").is_file());
    // an unknown method is a usage error
    let o = keycomp(&[
        "bench",
        "repeatability",
        "--data",
        s(&data),
        "--method",
        "sift",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

/// MSER key-components of TOSCA cat0 carried from poses cat1 and cat2 (identity map): the
/// repeatability the benchmark's isometry row is made of. Prints the numbers.
#[test]
fn mser_key_components_repeat_across_tosca_poses() {
    let Some(data) = shared_data("") else {
        return;
    };
    let params = MserParams::default();
    let null_path = data.join("tosca/cat0.off");
    let null = read_mesh(&null_path).expect("cat0").mesh;
    let areas = vertex_areas(&null);
    let on_null = detect(&null, &params)
        .expect("detect")
        .to_detection(&null, Output::KeyComponents)
        .expect("convert");
    let null_sets: Vec<Vec<u32>> = on_null
        .components
        .iter()
        .map(|c| c.vertices.clone())
        .collect();
    assert!(null_sets.len() >= 4, "cat0 has four limbs at least");
    for pose in ["cat1", "cat2"] {
        let mesh = read_mesh(&data.join(format!("tosca/{pose}.off")))
            .expect("pose")
            .mesh;
        assert_eq!(mesh.num_vertices(), null.num_vertices());
        let det = detect(&mesh, &params).expect("detect");
        let sets: Vec<Vec<u32>> = det
            .selected(Output::KeyComponents)
            .into_iter()
            .map(<[u32]>::to_vec)
            .collect();
        let best = best_overlaps(&null_sets, &sets, &areas);
        let mean = best.iter().sum::<f64>() / best.len().max(1) as f64;
        let rep = repeatability(&best, 0.8);
        println!(
            "MSER-KC cat0 vs {pose}: {} components, mean best overlap {mean:.3}, repeatability at 0.8 {rep:.3}",
            best.len()
        );
        assert!(!best.is_empty());
        assert!(mean > 0.6, "{pose}: mean best overlap {mean}");
    }
}
