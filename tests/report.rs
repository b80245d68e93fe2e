//! End-to-end test of `keycomp query --report`: a small collection generated in code is
//! indexed, queried with a report, and the page is loaded in a real headless Chromium to check
//! that every picture loads. Skipped with a message when no Chromium is installed.

mod common;

use std::path::Path;

use common::{chromium, headless, keycomp, s, stderr, stdout};
use keycomp_shapes::{Class, GenerateParams, generate};

/// Loads `page` in headless Chromium and returns the DOM after the load event.
fn dump_dom(browser: &Path, page: &Path, profile: &Path) -> String {
    let url = format!("file://{}", page.display());
    let out = headless(browser, profile)
        .args(["--allow-file-access-from-files", "--dump-dom", &url])
        .output()
        .expect("chromium runs");
    assert!(
        out.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn query_report_pictures_load_in_a_browser() {
    let tmp = tempfile::tempdir().expect("tempdir");
    // A directory name that needs escaping in HTML.
    let coll = tmp.path().join("shapes & <friends>");
    std::fs::create_dir(&coll).expect("mkdir");
    let params = GenerateParams {
        target_vertices: 8000,
        ..GenerateParams::default()
    };
    for class in [Class::Humanoid, Class::Mug] {
        for i in 0..2 {
            let shape = generate(class, i, &params).expect("generates");
            keycomp_mesh::write_off(&shape.mesh, &coll.join(format!("{}.off", shape.name)))
                .expect("writes");
        }
    }
    let index = tmp.path().join("index");
    let o = keycomp(&["index", "add", s(&coll), "--index", s(&index)]);
    assert!(o.status.success(), "{}", stderr(&o));

    // The query is a copy of an indexed shape, which is then changed on disk: its result row
    // must say so instead of showing a stale picture.
    let query = tmp.path().join("query.off");
    let changed = coll.join("mug-01.off");
    std::fs::copy(&changed, &query).expect("copy");
    let mut text = std::fs::read_to_string(&changed).expect("read");
    text.push_str("# edited after indexing\n");
    std::fs::write(&changed, text).expect("write");

    let report = tmp.path().join("report");
    let o = keycomp(&[
        "query",
        s(&query),
        "--index",
        s(&index),
        "-k",
        "4",
        "--report",
        s(&report),
    ]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("report: "), "{}", stdout(&o));
    let page = report.join("index.html");
    let html = std::fs::read_to_string(&page).expect("index.html");
    assert!(
        html.contains("shapes &amp; &lt;friends&gt;"),
        "paths are escaped"
    );
    assert!(!html.contains("<friends>"));
    assert!(
        html.contains("changed since it was indexed"),
        "the changed result is flagged"
    );
    // Every referenced picture exists and is a PNG.
    let srcs: Vec<&str> = html
        .split("src=\"")
        .skip(1)
        .filter_map(|t| t.split('"').next())
        .collect();
    assert!(
        srcs.len() >= 2,
        "the query and at least one result have pictures"
    );
    for src in &srcs {
        let bytes = std::fs::read(report.join(src)).expect("picture exists");
        assert!(bytes.starts_with(b"\x89PNG"), "{src} is a PNG");
    }
    // Nothing but the report is left beside it (the temporary directory was renamed).
    let leftovers: Vec<_> = std::fs::read_dir(tmp.path())
        .expect("ls")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // A second report replaces the first one in place.
    let o = keycomp(&[
        "query",
        s(&query),
        "--index",
        s(&index),
        "--report",
        s(&report),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A directory that is not a report is never replaced.
    let other = tmp.path().join("not-a-report");
    std::fs::create_dir(&other).expect("mkdir");
    std::fs::write(other.join("precious.txt"), "keep me").expect("write");
    let o = keycomp(&[
        "query",
        s(&query),
        "--index",
        s(&index),
        "--report",
        s(&other),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("not a keycomp report"),
        "{}",
        stderr(&o)
    );
    assert!(other.join("precious.txt").is_file());

    // The browser: a copy of the page with a script that records, after the load event, how
    // many pictures decoded.
    let Some(browser) = chromium() else {
        eprintln!("skipping the browser check: no chromium found (apt-get install chromium)");
        return;
    };
    let probe = report.join("probe.html");
    let script = "<script>window.addEventListener('load', () => {
        const imgs = Array.from(document.images);
        const ok = imgs.filter(i => i.complete && i.naturalWidth > 0);
        document.body.setAttribute('data-images', imgs.length + '/' + ok.length);
    });</script></body>";
    std::fs::write(&probe, html.replace("</body>", script)).expect("probe");
    let profile = tmp.path().join("chromium-profile");
    let dom = dump_dom(&browser, &probe, &profile);
    let attr = dom
        .split("data-images=\"")
        .nth(1)
        .and_then(|t| t.split('"').next())
        .unwrap_or_else(|| panic!("the page did not run its probe: {dom}"));
    let (total, ok) = attr.split_once('/').expect("n/m");
    assert_eq!(total, srcs.len().to_string(), "every picture is an <img>");
    assert_eq!(ok, total, "pictures that loaded in chromium: {attr}");
}
