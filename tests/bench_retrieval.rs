//! End-to-end tests of `keycomp bench retrieval` (issue 6): a synthetic labelled collection
//! generated here, argument errors, and (when ../shared/data is present) a FAUST subset.

// the helpers below are test code too: a failed unwrap is a failed test
#![allow(clippy::unwrap_used)]

mod common;

use std::path::{Path, PathBuf};

use common::{keycomp, s, stderr, stdout};
use keycomp_mesh::{Mesh, Point3, synth, write_off};
use keycomp_test_support::shared_data;
use serde_json::Value;

/// Three classes of three shapes each, written as OFF files into the new folder `dir/shapes`
/// (returned): spheres with bumps of different heights, tori of different thickness,
/// ellipsoids of different proportions.
fn synthetic_collection(dir: &Path) -> PathBuf {
    let dir = dir.join("shapes");
    std::fs::create_dir(&dir).unwrap();
    let scaled = |m: Mesh, s: [f64; 3]| Mesh {
        positions: m
            .positions
            .iter()
            .map(|p| Point3::new(p.x * s[0], p.y * s[1], p.z * s[2]))
            .collect(),
        faces: m.faces,
    };
    for (i, h) in [0.4, 0.5, 0.6].into_iter().enumerate() {
        write_off(
            &synth::protrusion_sphere(5, h, 0.4),
            &dir.join(format!("bumpy{i}.off")),
        )
        .unwrap();
    }
    for (i, r) in [0.25, 0.3, 0.35].into_iter().enumerate() {
        write_off(
            &synth::torus(1.0, r, 160, 64),
            &dir.join(format!("torus{i}.off")),
        )
        .unwrap();
    }
    for (i, sc) in [[2.0, 1.0, 1.0], [2.2, 1.0, 0.9], [1.8, 1.1, 1.0]]
        .into_iter()
        .enumerate()
    {
        write_off(
            &scaled(synth::icosphere(5, 1.0), sc),
            &dir.join(format!("ellipsoid{i}.off")),
        )
        .unwrap();
    }
    dir
}

fn results(out: &Path) -> Value {
    let text = std::fs::read_to_string(out.join("results.json")).expect("results.json written");
    serde_json::from_str(&text).expect("valid JSON")
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// Every per-query score is in [0, 1], NN agrees with the first result's class, source ranks
/// are within the collection, and the summary is the mean of the queries.
fn check_consistency(r: &Value, class_of: &dyn Fn(&str) -> String) {
    let n = r["shapes"].as_u64().unwrap() as usize;
    for set in r["query_sets"].as_array().unwrap() {
        let qs = set["results"].as_array().unwrap();
        assert_eq!(set["queries"].as_u64().unwrap() as usize, qs.len());
        for method in ["key_components", "d2"] {
            let mut nn_sum = 0.0;
            let mut ap_sum = 0.0;
            let mut defined = 0;
            let mut verified = 0;
            for q in qs {
                let m = &q[method];
                // candidate recall: recorded for key-components' queries with a source only
                match (method, q["source"].is_null()) {
                    ("key_components", false) => {
                        let v = m["source_verified"].as_bool().expect("source_verified");
                        verified += usize::from(v);
                    }
                    _ => assert!(m["source_verified"].is_null(), "{q}"),
                }
                let top = m["top"].as_array().unwrap();
                assert!(!top.is_empty() && top.len() <= 5);
                if q["source"].is_null() {
                    // whole-shape query: never itself
                    assert!(top.iter().all(|t| t != &q["query"]), "{q}");
                } else {
                    let rank = m["source_rank"].as_u64().unwrap() as usize;
                    assert!((1..=n).contains(&rank), "{q}");
                    // a cut fragment's area fraction (external queries have none)
                    if !q["fraction"].is_null() {
                        let fr = f(&q["fraction"]);
                        assert!(fr > 0.0 && fr <= 1.0, "{q}");
                    }
                }
                if m["nn"].is_null() {
                    continue;
                }
                defined += 1;
                for k in ["nn", "ft", "st", "e", "dcg", "ap"] {
                    let v = f(&m[k]);
                    assert!((0.0..=1.0 + 1e-9).contains(&v), "{method} {k} = {v}");
                }
                assert!(f(&m["ft"]) <= f(&m["st"]) + 1e-12);
                let first_class = class_of(top[0].as_str().unwrap());
                let expect_nn = if first_class == q["class"].as_str().unwrap() {
                    1.0
                } else {
                    0.0
                };
                assert_eq!(f(&m["nn"]), expect_nn, "{method} {q}");
                nn_sum += f(&m["nn"]);
                ap_sum += f(&m["ap"]);
            }
            let summary = &set[method];
            assert_eq!(summary["queries"].as_u64().unwrap(), defined);
            if method == "key_components" && qs.iter().any(|q| !q["source"].is_null()) {
                assert_eq!(summary["source_verified"].as_u64(), Some(verified as u64));
            } else {
                assert!(summary["source_verified"].is_null());
            }
            if defined > 0 {
                let d = defined as f64;
                assert!((f(&summary["mean"]["nn"]) - nn_sum / d).abs() < 1e-9);
                assert!((f(&summary["mean"]["ap"]) - ap_sum / d).abs() < 1e-9);
                let pr = summary["mean"]["pr"].as_array().unwrap();
                assert_eq!(pr.len(), 21);
            }
        }
    }
}

fn prefix_class(name: &str) -> String {
    name.trim_end_matches(|c: char| c.is_ascii_digit())
        .to_string()
}

#[test]
fn synthetic_collection_end_to_end() {
    let tmp = tempfile::tempdir().unwrap();
    let coll = synthetic_collection(tmp.path());
    let out = tmp.path().join("out");
    let args = [
        "bench",
        "retrieval",
        "--collection",
        s(&coll),
        "--partial",
        "ball,scan",
        "--queries",
        "3",
        "--seed",
        "5",
        "--d2-pairs",
        "65536",
        // the synthetic shapes have about 100 keypoints each, and the default N finds
        // components on few of them; N = 8 finds them on the bumpy spheres and tori, so the
        // key-component path has something to rank (and `--detect` is exercised)
        "--detect",
        "--preset kc1 --n 8",
        "--out",
        s(&out),
    ];
    let o = keycomp(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    eprintln!("{text}");
    assert!(text.contains("| whole | 9 |"), "{text}");
    assert!(
        text.contains("key-components") && text.contains("D2"),
        "{text}"
    );
    for file in ["results.json", "pr-whole.svg", "pr-ball.svg", "pr-scan.svg"] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    assert!(out.join("index").is_dir());
    let svg = std::fs::read_to_string(out.join("pr-whole.svg")).unwrap();
    assert!(svg.contains("<polyline") && svg.contains(">Recall<"));
    let frags: Vec<PathBuf> = std::fs::read_dir(out.join("fragments"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(frags.len(), 6, "{frags:?}");

    let r = results(&out);
    assert_eq!(r["shapes"], 9);
    assert_eq!(r["classes"]["torus"], 3);
    let sets: Vec<&str> = r["query_sets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(sets, ["whole", "ball", "scan"]);
    check_consistency(&r, &prefix_class);
    // whole shapes of three very different kinds: D2 tells them apart (chance mAP ≈ 0.3)
    let whole = &r["query_sets"][0];
    assert!(f(&whole["d2"]["mean"]["ap"]) > 0.6, "{}", whole["d2"]);
    // with N = 8 the bumpy spheres and tori have key-components, and the product's ranking
    // finds their classes (a random ranking has mAP ≈ 0.35 here)
    assert!(
        f(&r["components_per_shape"]) > 0.5,
        "{}",
        r["components_per_shape"]
    );
    assert!(
        f(&whole["key_components"]["mean"]["ap"]) > 0.5,
        "{}",
        whole["key_components"]
    );
    // fragments keep the area they report, within the requested 20-60 % (a scan may see less)
    for set in &r["query_sets"].as_array().unwrap()[1..] {
        for q in set["results"].as_array().unwrap() {
            let (t, fr) = (f(&q["target_fraction"]), f(&q["fraction"]));
            assert!((0.2..=0.6).contains(&t), "{q}");
            if set["name"] == "ball" {
                assert!(fr >= t - 1e-9 && fr < t + 0.02, "{q}");
            } else {
                assert!(fr < t + 0.02, "{q}");
            }
        }
    }

    // a second run reuses the cache and gives the same results, byte for byte
    let first = std::fs::read(out.join("results.json")).unwrap();
    let o = keycomp(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("9 of 9 records from the cache"),
        "{}",
        stdout(&o)
    );
    assert_eq!(first, std::fs::read(out.join("results.json")).unwrap());

    // labels from a CSV: one class for all but one shape, in a class of its own: its query is
    // undefined and left out (PSB), every other query has near-perfect scores
    let csv = tmp.path().join("labels.csv");
    let lines: String = std::fs::read_dir(&coll)
        .unwrap()
        .map(|e| {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            let class = if name == "torus0.off" { "alone" } else { "all" };
            format!("{name},{class}\n")
        })
        .collect();
    std::fs::write(&csv, lines).unwrap();
    let out2 = tmp.path().join("out2");
    let o = keycomp(&[
        "bench",
        "retrieval",
        "--collection",
        s(&coll),
        "--labels",
        s(&csv),
        "--partial",
        "none",
        "--d2-pairs",
        "4096",
        "--out",
        s(&out2),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("1 queries left out of the means"),
        "{}",
        stdout(&o)
    );
    let r = results(&out2);
    assert_eq!(r["query_sets"].as_array().unwrap().len(), 1);
    for method in ["key_components", "d2"] {
        let summary = &r["query_sets"][0][method];
        assert_eq!(
            (summary["queries"].as_u64(), summary["undefined"].as_u64()),
            (Some(8), Some(1))
        );
        // each list holds 7 relevant shapes and the lone torus0: at worst torus0 comes first,
        // giving FT 6/7 and AP (1/2 + 2/3 + … + 7/8) / 7
        let worst_ap = (1..=7).map(|k| k as f64 / (k + 1) as f64).sum::<f64>() / 7.0;
        for q in r["query_sets"][0]["results"].as_array().unwrap() {
            let m = &q[method];
            if q["query"] == "torus0" {
                assert!(m["ap"].is_null(), "{q}");
                continue;
            }
            assert!(f(&m["ft"]) >= 6.0 / 7.0 - 1e-12, "{q}");
            assert!(f(&m["st"]) == 1.0, "{q}");
            assert!(f(&m["ap"]) >= worst_ap - 1e-12, "{q}");
        }
    }
}

/// `--queries DIR --truth CSV`: files of any kind keycomp reads, measured as the set
/// 'external' with the baselines; an exact copy of a collection shape finds it first; a bare
/// point cloud is ranked too; truth that names nothing is refused with its file and line.
#[test]
fn external_queries_with_their_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let coll = synthetic_collection(tmp.path());
    let queries = tmp.path().join("queries");
    std::fs::create_dir(&queries).unwrap();
    std::fs::copy(coll.join("torus1.off"), queries.join("copy.off")).unwrap();
    let cloud: String = synth::protrusion_sphere(5, 0.6, 0.4)
        .positions
        .iter()
        .map(|p| format!("{} {} {}\n", p.x, p.y, p.z))
        .collect();
    std::fs::write(queries.join("bumps.xyz"), cloud).unwrap();
    let truth = tmp.path().join("truth.csv");
    std::fs::write(
        &truth,
        "query,source\ncopy.off,torus1\nbumps,bumpy2.off,bumpy\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    let run = |truth: &Path, out: &Path| {
        keycomp(&[
            "bench",
            "retrieval",
            "--collection",
            s(&coll),
            "--queries",
            s(&queries),
            "--truth",
            s(truth),
            "--partial",
            "none",
            "--d2-pairs",
            "4096",
            "--detect",
            "--preset kc1 --n 8",
            "--out",
            s(out),
        ])
    };
    let o = run(&truth, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("| external | 2 |"), "{}", stdout(&o));
    let r = results(&out);
    let sets: Vec<&str> = r["query_sets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(sets, ["whole", "external"]);
    check_consistency(&r, &prefix_class);
    let ext = r["query_sets"][1]["results"].as_array().unwrap();
    assert_eq!(ext[0]["source"], "torus1");
    assert_eq!(ext[0]["class"], "torus");
    assert_eq!(ext[0]["key_components"]["source_rank"], 1, "{}", ext[0]);
    assert_eq!(ext[0]["d2"]["source_rank"], 1, "{}", ext[0]);
    assert_eq!(ext[1]["source"], "bumpy2");
    assert!(ext[1]["query"].as_str().unwrap().ends_with("bumps.xyz"));
    assert!(
        ext[1]["fpfh_bow"]["source_rank"].as_u64().is_some(),
        "{}",
        ext[1]
    );
    // truth naming a shape the collection does not have, and the options alone
    std::fs::write(&truth, "copy.off,torus9\n").unwrap();
    let o = run(&truth, &tmp.path().join("out2"));
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("truth.csv:1") && stderr(&o).contains("'torus9'"),
        "{}",
        stderr(&o)
    );
    for extra in [["--truth", s(&truth)], ["--queries", s(&queries)]] {
        let mut a = vec!["bench", "retrieval", "--collection", s(&coll)];
        a.extend_from_slice(&extra);
        let o = keycomp(&a);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains("--truth"), "{}", stderr(&o));
    }
}

#[test]
fn bad_arguments_exit_2_with_a_clear_message() {
    let tmp = tempfile::tempdir().unwrap();
    let coll = tmp.path().join("c");
    std::fs::create_dir(&coll).unwrap();
    let out = tmp.path().join("out");
    let run = |extra: &[&str]| {
        let mut a = vec!["bench", "retrieval", "--out", s(&out)];
        a.extend_from_slice(extra);
        keycomp(&a)
    };
    // not a folder
    let o = run(&["--collection", s(&tmp.path().join("missing"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing") && stderr(&o).contains("not a folder"));
    // too few shapes
    let o = run(&["--collection", s(&coll)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("at least 2"), "{}", stderr(&o));
    write_off(&synth::icosphere(1, 1.0), &coll.join("a1.off")).unwrap();
    write_off(&synth::icosphere(1, 1.0), &coll.join("b1.off")).unwrap();
    // a regex that does not match, or does not compile
    let o = run(&["--collection", s(&coll), "--class-from-name", "^z(.)"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("does not match the file name 'a1'"),
        "{}",
        stderr(&o)
    );
    let o = run(&["--collection", s(&coll), "--class-from-name", "("]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("invalid regular expression"),
        "{}",
        stderr(&o)
    );
    // unknown partial kind, bad fraction range, labels file missing
    let o = run(&["--collection", s(&coll), "--partial", "cube"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown partial query kind 'cube'"),
        "{}",
        stderr(&o)
    );
    let o = run(&["--collection", s(&coll), "--area", "0.7,0.2"]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["--collection", s(&coll), "--detect", "--preset kc9"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("kc9"), "{}", stderr(&o));
    let o = run(&[
        "--collection",
        s(&coll),
        "--labels",
        "/nonexistent/labels.csv",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("labels.csv"), "{}", stderr(&o));
    // a broken mesh file is named
    std::fs::write(coll.join("c1.off"), "OFF\n3 1 0\n0 0 0\n").unwrap();
    let o = run(&["--collection", s(&coll), "--partial", "none"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("c1.off"), "{}", stderr(&o));
    assert!(
        !out.join("results.json").exists(),
        "no results from a failed run"
    );
}

/// Twenty FAUST registrations (subjects 0 and 1, all poses) linked into a temporary folder,
/// class = subject. Checks the run on real scans completes and is internally consistent; the
/// full TOSCA and FAUST numbers of BENCHMARKS.md come from the commands documented there.
#[cfg(unix)]
#[test]
fn faust_subset_real_data() {
    let Some(data) = shared_data("") else { return };
    let faust = data.join("faust");
    let tmp = tempfile::tempdir().unwrap();
    let coll = tmp.path().join("faust");
    std::fs::create_dir(&coll).unwrap();
    for i in 0..20 {
        let name = format!("tr_reg_{i:03}.ply");
        std::os::unix::fs::symlink(faust.join(&name), coll.join(&name)).unwrap();
    }
    let out = tmp.path().join("out");
    let o = keycomp(&[
        "bench",
        "retrieval",
        "--collection",
        s(&coll),
        "--class-from-name",
        r"tr_reg_\d(\d)\d",
        "--partial",
        "plane",
        "--queries",
        "4",
        "--d2-pairs",
        "65536",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    eprintln!("{}", stdout(&o));
    let r = results(&out);
    assert_eq!(r["classes"]["0"], 10);
    assert_eq!(r["classes"]["1"], 10);
    check_consistency(&r, &|name: &str| {
        name.trim_start_matches("tr_reg_")
            .chars()
            .nth(1)
            .map(String::from)
            .unwrap_or_default()
    });
}
