//! End-to-end test of `keycomp demo` on a small collection: the table, the summary, the
//! report, determinism, and a re-run that indexes nothing twice.

mod common;

use common::{keycomp, s, stderr, stdout};

/// The table without its time column (the last field of each query row and the timings of
/// the report line).
fn without_times(out: &str) -> Vec<String> {
    out.lines()
        .filter(|l| !l.starts_with("report:"))
        .map(|l| {
            if l.contains(" hit ") || l.contains(" miss ") {
                l.rsplit_once(' ')
                    .map(|x| x.0.trim_end())
                    .unwrap_or(l)
                    .to_string()
            } else {
                l.to_string()
            }
        })
        .collect()
}

#[test]
fn demo_runs_reports_and_reruns_without_duplicates() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("out");
    let index = tmp.path().join("index");
    let args = [
        "demo",
        "--out",
        s(&out),
        "--index",
        s(&index),
        "--per-class",
        "2",
        "--vertices",
        "8000",
    ];
    let first = keycomp(&args);
    assert!(first.status.success(), "{}", stderr(&first));
    let text = stdout(&first);
    // 7 classes: a held-out whole shape and a fragment each.
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| l.contains(" hit ") || l.contains(" miss "))
        .collect();
    assert_eq!(rows.len(), 14, "{text}");
    for class in [
        "quadruped",
        "humanoid",
        "bird",
        "octopus",
        "snake",
        "mug",
        "fish",
    ] {
        assert!(
            rows.iter().any(|r| r.starts_with(&format!("{class}-02 "))),
            "{class}'s held-out query: {text}"
        );
    }
    assert!(text.contains("top-1 class: "), "{text}");
    assert!(stderr(&first).contains("14 added"), "{}", stderr(&first));
    assert_eq!(
        std::fs::read_dir(out.join("collection"))
            .expect("ls")
            .count(),
        14
    );
    let html = std::fs::read_to_string(out.join("report/index.html")).expect("report");
    assert_eq!(html.matches("<h2>").count(), 14);

    // Same table again; nothing indexed twice.
    let second = keycomp(&args);
    assert!(second.status.success(), "{}", stderr(&second));
    assert!(
        stderr(&second).contains("0 added, 14 already there"),
        "{}",
        stderr(&second)
    );
    assert_eq!(without_times(&text), without_times(&stdout(&second)));
    let list = keycomp(&["index", "list", "--index", s(&index), "--json"]);
    let shapes: serde_json::Value = serde_json::from_slice(&list.stdout).expect("json");
    assert_eq!(shapes.as_array().map(|a| a.len()), Some(14), "{shapes}");
}

#[test]
fn demo_rejects_bad_arguments() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let o = keycomp(&["demo", "--out", s(tmp.path()), "--per-class", "0"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--per-class"), "{}", stderr(&o));
    let o = keycomp(&["demo", "--out", s(tmp.path()), "--vertices", "100"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("at least 4000"), "{}", stderr(&o));
}
