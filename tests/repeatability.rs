//! End-to-end tests of `keycomp transform` and `keycomp bench repeatability`: the real binary
//! on files written here.

mod common;

use std::fs;
use std::path::{Path, PathBuf};

use keycomp_mesh::{Mesh, Point3, read_mesh, synth, write_off};
use serde_json::Value;

use common::{keycomp, s, stderr};

/// Two spheres 0.05 apart (1,284 vertices): parts close in space but far apart along the
/// surface, so `topology` finds weld sites.
fn write_null(dir: &Path) -> (PathBuf, Mesh) {
    let a = synth::icosphere(3, 1.0);
    let off = a.positions.len() as u32;
    let mut positions = a.positions.clone();
    positions.extend(
        a.positions
            .iter()
            .map(|p| Point3::new(p.x + 2.05, p.y, p.z)),
    );
    let mut faces = a.faces.clone();
    faces.extend(a.faces.iter().map(|f| f.map(|v| v + off)));
    let mesh = Mesh { positions, faces };
    let path = dir.join("null.off");
    write_off(&mesh, &path).expect("write OFF");
    (path, mesh)
}

/// Reads a map file: the header's null count and the entries.
fn read_map_file(path: &Path) -> (usize, Vec<i64>) {
    let text = fs::read_to_string(path).expect("map written");
    let mut lines = text.lines();
    let header = lines.next().expect("header");
    assert!(header.starts_with("# keycomp-map v1 "), "{header}");
    let null: usize = header
        .split_whitespace()
        .find_map(|t| t.strip_prefix("null="))
        .expect("null=")
        .parse()
        .expect("count");
    let entries = lines
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| l.trim().parse().expect("an id"))
        .collect();
    (null, entries)
}

#[test]
fn transform_writes_a_valid_mesh_and_map_for_every_kind() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (null_path, null) = write_null(dir.path());
    let n = null.num_vertices();
    for kind in [
        "holes",
        "microholes",
        "noise",
        "shotnoise",
        "scale",
        "localscale",
        "topology",
        "sampling",
    ] {
        let out = dir.path().join(format!("{kind}.off"));
        let o = keycomp(&[
            "transform",
            s(&null_path),
            "--kind",
            kind,
            "--strength",
            "2",
            "--seed",
            "5",
            "-o",
            s(&out),
        ]);
        assert!(o.status.success(), "{kind}: {}", stderr(&o));
        let mesh = read_mesh(&out).expect("a valid mesh").mesh;
        // the default map path is the mesh's with .map
        let (null_count, map) = read_map_file(&out.with_extension("map"));
        assert_eq!(null_count, n, "{kind}");
        assert_eq!(map.len(), mesh.num_vertices(), "{kind}");
        assert!(
            map.iter().all(|&t| t == -1 || (0..n as i64).contains(&t)),
            "{kind}: ids out of range"
        );
        // deterministic for a seed
        let again = dir.path().join(format!("{kind}-again.off"));
        let o = keycomp(&[
            "transform",
            s(&null_path),
            "--kind",
            kind,
            "--strength",
            "2",
            "--seed",
            "5",
            "-o",
            s(&again),
            "--map",
            s(&dir.path().join("again.map")),
        ]);
        assert!(o.status.success(), "{kind}: {}", stderr(&o));
        assert_eq!(
            fs::read(&out).expect("mesh"),
            fs::read(&again).expect("mesh"),
            "{kind}"
        );
    }
}

#[test]
fn transform_sampling_reduces_the_vertex_count_with_strength() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (null_path, null) = write_null(dir.path());
    let mut last = null.num_vertices();
    for strength in 1..=5 {
        let out = dir.path().join(format!("s{strength}.off"));
        let map = dir.path().join(format!("s{strength}.map"));
        let o = keycomp(&[
            "transform",
            s(&null_path),
            "--kind",
            "sampling",
            "--strength",
            &strength.to_string(),
            "-o",
            s(&out),
            "--map",
            s(&map),
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).expect("JSON summary");
        let vertices = read_mesh(&out).expect("mesh").mesh.num_vertices();
        assert_eq!(v["vertices"], vertices);
        assert!(vertices < last, "strength {strength}: {vertices} ≥ {last}");
        assert_eq!(read_map_file(&map).1.len(), vertices);
        last = vertices;
    }
}

#[test]
fn transform_bad_arguments_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (null_path, _) = write_null(dir.path());
    let out = dir.path().join("out.off");
    let o_str = s(&out).to_owned();
    let null_str = s(&null_path).to_owned();
    let missing = s(&dir.path().join("missing.off")).to_owned();
    let ply = s(&dir.path().join("out.ply")).to_owned();
    let no_dir = s(&dir.path().join("no/such/out.off")).to_owned();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                &null_str,
                "--kind",
                "twist",
                "--strength",
                "1",
                "-o",
                &o_str,
            ],
            "twist",
        ),
        (
            vec![
                &null_str,
                "--kind",
                "noise",
                "--strength",
                "6",
                "-o",
                &o_str,
            ],
            "6",
        ),
        (
            vec![
                &null_str,
                "--kind",
                "noise",
                "--strength",
                "0",
                "-o",
                &o_str,
            ],
            "0",
        ),
        (
            vec![&missing, "--kind", "noise", "--strength", "1", "-o", &o_str],
            "missing.off",
        ),
        (
            vec![&null_str, "--kind", "noise", "--strength", "1", "-o", &ply],
            "out.ply",
        ),
        (
            vec![
                &null_str,
                "--kind",
                "noise",
                "--strength",
                "1",
                "-o",
                &no_dir,
            ],
            "does not exist",
        ),
        (
            vec![&null_str, "--kind", "noise", "--strength", "1"],
            "--output",
        ),
    ];
    for (args, needle) in cases {
        let mut full = vec!["transform"];
        full.extend(args.iter().copied());
        let o = keycomp(&full);
        assert_eq!(o.status.code(), Some(2), "{full:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{full:?}: {}", stderr(&o));
    }
    // topology on a convex shape cannot be applied: exit 2, nothing written
    let ball = dir.path().join("ball.off");
    write_off(&synth::icosphere(3, 1.0), &ball).expect("write");
    let o = keycomp(&[
        "transform",
        s(&ball),
        "--kind",
        "topology",
        "--strength",
        "1",
        "-o",
        &o_str,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("ball.off"), "{}", stderr(&o));
    let left: Vec<_> = fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(left.len(), 2, "only the inputs remain: {left:?}");
}

/// The tiny data folder: one textured protrusion sphere (10k vertices).
fn tiny_data(dir: &Path) -> PathBuf {
    let data = dir.join("data");
    fs::create_dir_all(&data).expect("mkdir");
    write_off(
        &synth::textured_protrusion_sphere(5),
        &data.join("proto.off"),
    )
    .expect("write");
    data
}

#[test]
fn bench_repeatability_on_a_tiny_folder_writes_sane_json_and_svg() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = tiny_data(dir.path());
    let out = dir.path().join("out");
    let args = [
        "bench",
        "repeatability",
        "--data",
        s(&data),
        "--preset",
        "all",
        "--kinds",
        "noise,scale",
        "--strengths",
        "1,2",
        // the paper's N = 30 finds nothing on a 10k-vertex shape (102 keypoints)
        "--n",
        "8",
        // the paper's experiment: the shapes as generated
        "--surface",
        "as-read",
        "--out",
        s(&out),
    ];
    let o = keycomp(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("KC-1*"), "{text}");
    assert!(text.contains("| Scale | 1.00 / 0.95"), "{text}");

    let results: Value =
        serde_json::from_slice(&fs::read(out.join("results.json")).expect("results.json"))
            .expect("valid JSON");
    assert_eq!(results["format"], "keycomp-repeatability v1");
    let presets = results["presets"].as_array().expect("presets");
    assert_eq!(presets.len(), 3);
    for p in presets {
        let rows = p["mean_overlap"]["rows"].as_array().expect("rows");
        let kinds: Vec<&str> = rows
            .iter()
            .map(|r| r["kind"].as_str().expect("kind"))
            .collect();
        assert_eq!(kinds, ["scale", "noise"]);
        let scale = rows[0]["values"][1]
            .as_f64()
            .expect("scale ≤ 2 has components");
        assert!(scale > 0.999, "scale invariance: {scale}");
        for v in rows[1]["values"].as_array().expect("values") {
            if let Some(x) = v.as_f64() {
                assert!((0.0..=1.0).contains(&x));
            }
        }
        assert_eq!(p["curves"].as_array().expect("curves").len(), 2);
        assert!(
            p["paper"]["source"]
                .as_str()
                .expect("paper")
                .contains("Table")
        );
    }
    // 1 null + 2 kinds × 2 strengths
    assert_eq!(results["shapes"].as_array().expect("shapes").len(), 5);
    for tag in ["kc1-modified", "kc2-modified", "kc3-modified"] {
        let svg = fs::read_to_string(out.join(format!("repeatability-{tag}.svg"))).expect("svg");
        assert!(svg.starts_with("<svg"), "{tag}");
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<polyline").count(), 2, "{tag}");
        assert!(svg.contains("Scale (") && svg.contains("Noise ("), "{tag}");
    }
    assert!(out.join("tables.md").is_file());
    let run: Value =
        serde_json::from_slice(&fs::read(out.join("run.json")).expect("run.json")).expect("JSON");
    assert_eq!(run["stats"]["computed"], 5);

    // a re-run reads every detection from the cache and gives the same results
    let o = keycomp(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let run: Value =
        serde_json::from_slice(&fs::read(out.join("run.json")).expect("run.json")).expect("JSON");
    assert_eq!(run["stats"]["cache_hits"], 5);
    let again: Value =
        serde_json::from_slice(&fs::read(out.join("results.json")).expect("results.json"))
            .expect("JSON");
    assert_eq!(again, results);

    // corrupt cache entries are ignored and recomputed
    for e in fs::read_dir(out.join("cache")).expect("cache") {
        fs::write(e.expect("entry").path(), b"garbage").expect("corrupt");
    }
    let o = keycomp(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let run: Value =
        serde_json::from_slice(&fs::read(out.join("run.json")).expect("run.json")).expect("JSON");
    assert_eq!(run["stats"]["corrupt_entries"], 5);
    let again: Value =
        serde_json::from_slice(&fs::read(out.join("results.json")).expect("results.json"))
            .expect("JSON");
    assert_eq!(again, results);
}

#[test]
fn bench_repeatability_runs_the_robust_preset_by_default() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = tiny_data(dir.path());
    let out = dir.path().join("out");
    let o = keycomp(&[
        "bench",
        "repeatability",
        "--data",
        s(&data),
        "--kinds",
        "scale",
        "--strengths",
        "1",
        "--n",
        "8",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    // read beside the paper's KC-1, the default it replaces
    assert!(text.contains("### robust*"), "{text}");
    assert!(
        text.contains("salient peaks: t 0.02, prominence 0.4, radius 0.15, at most 12"),
        "{text}"
    );
    assert!(
        text.contains("Harris after smoothing over 0.0257 unit lengths"),
        "{text}"
    );
    assert!(
        text.contains("Keypoint budget: 400 keypoints per unit area"),
        "{text}"
    );
    assert!(text.contains("Table 1)"), "{text}");
    let results: Value =
        serde_json::from_slice(&fs::read(out.join("results.json")).expect("results.json"))
            .expect("valid JSON");
    let presets = results["presets"].as_array().expect("presets");
    assert_eq!(presets.len(), 1);
    assert_eq!(presets[0]["preset"]["name"], "robust*");
    assert_eq!(results["harris"]["smoothing_length"], 0.0257);
    assert_eq!(results["surface"]["vertices"], 10_000);
    assert_eq!(results["smacof"]["starts"], 1);
    // a uniform scaling changes nothing: the canonical surface is scaled with the shape and
    // the robust components repeat exactly
    let scale = presets[0]["mean_overlap"]["rows"][0]["values"][0]
        .as_f64()
        .expect("scale 1 has components");
    assert!(scale > 0.99, "scale overlap {scale}");
}

#[test]
fn bench_repeatability_bad_arguments_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = tiny_data(dir.path());
    let missing = dir.path().join("nothing-here");
    let out = dir.path().join("out");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--data", s(&missing)], "nothing-here"),
        (vec!["--data", s(&data), "--kinds", "twist"], "twist"),
        (vec!["--data", s(&data), "--strengths", "0"], "0"),
        (vec!["--data", s(&data), "--preset", "kc9"], "kc9"),
        (
            vec![
                "--data",
                s(&data),
                "--tessellation-independent",
                "--count",
                "5",
            ],
            "--count",
        ),
        (vec!["--data", s(&data), "--r", "0.5"], "cluster"),
        (
            vec!["--data", s(&data), "--smoothing", "5000"],
            "smoothing_iterations",
        ),
        (vec!["--data", s(&data), "--sphere", "spread:0"], "spread:0"),
        (vec!["--data", s(&data), "--sphere", "ball"], "ball"),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["bench", "repeatability", "--out", s(&out)];
        args.extend(extra.iter().copied());
        let o = keycomp(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
}
