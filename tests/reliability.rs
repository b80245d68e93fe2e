//! End-to-end tests of how the binary treats hostile or unusual files and arguments: inputs
//! that are not regular files, outputs that are links, devices or folders, crafted index files,
//! negative numbers, and commands that must leave nothing behind when they fail.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use keycomp_mesh::{synth, write_off};

use common::{keycomp, s, stderr};

/// Writes a small synthetic shape as OFF at `path`.
fn small_off(path: &Path) -> PathBuf {
    write_off(&synth::protrusion_sphere(3, 0.8, 0.25), path).expect("write OFF");
    path.to_path_buf()
}

/// Makes a FIFO at `path`; false (after a skip message) where `mkfifo` is missing.
fn mkfifo(path: &Path) -> bool {
    match Command::new("mkfifo").arg(path).status() {
        Ok(st) if st.success() => true,
        _ => {
            eprintln!("skipping: mkfifo is not available");
            false
        }
    }
}

#[cfg(unix)]
fn is_fifo(path: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo())
}

/// A FIFO given as the mesh is refused at once (it used to block forever waiting for a writer).
#[cfg(unix)]
#[test]
fn a_fifo_input_is_refused_not_waited_on() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("mesh.off");
    if !mkfifo(&fifo) {
        return;
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_keycomp"))
        .args(["detect", s(&fifo)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let start = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("keycomp detect FIFO is still waiting after 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = child.wait_with_output().expect("output");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(status.code(), Some(2), "{err}");
    assert!(err.contains("FIFO") && err.contains("mesh.off"), "{err}");
}

/// Outputs: a symbolic link is followed (the link stays), a device is written in place (it is
/// not replaced by a regular file), a FIFO gets the bytes, a folder or a missing folder is an
/// error naming the path.
#[cfg(unix)]
#[test]
fn outputs_follow_links_write_devices_and_refuse_folders() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mesh = small_off(&dir.path().join("m.off"));
    let m = s(&mesh);

    let o = keycomp(&["keypoints", m, "--ply", "/dev/null"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!std::fs::metadata("/dev/null").expect("/dev/null").is_file());

    let real = dir.path().join("real.ply");
    std::fs::write(&real, "old").expect("write");
    let link = dir.path().join("link.ply");
    std::os::unix::fs::symlink("real.ply", &link).expect("symlink");
    let o = keycomp(&["keypoints", m, "--ply", s(&link)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let link_meta = std::fs::symlink_metadata(&link).expect("link");
    assert!(link_meta.file_type().is_symlink(), "the link was replaced");
    assert!(std::fs::read(&real).expect("read").starts_with(b"ply\n"));

    let fifo = dir.path().join("out.ply");
    if mkfifo(&fifo) {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).expect("read the FIFO"))
        };
        let o = keycomp(&["detect", m, "--ply", s(&fifo)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(reader.join().expect("reader").starts_with(b"ply\n"));
        assert!(is_fifo(&fifo), "the FIFO was replaced");
    }

    let o = keycomp(&["keypoints", m, "--ply", s(dir.path())]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("is a directory"), "{}", stderr(&o));

    let missing = dir.path().join("no/such/out.ply");
    let o = keycomp(&["keypoints", m, "--ply", s(&missing)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));

    let o = keycomp(&[
        "render",
        m,
        "-o",
        s(&dir.path().join("no/such.png")),
        "--size",
        "64",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
}

/// `--report` follows the same rule as files: the folder above it must exist, checked before
/// any work, and nothing is created when it does not.
#[test]
fn a_report_in_a_missing_folder_is_refused_up_front() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mesh = small_off(&dir.path().join("m.off"));
    let report = dir.path().join("no/such/report");
    let o = keycomp(&[
        "query",
        s(&mesh),
        "--index",
        s(&dir.path().join("index")),
        "--report",
        s(&report),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
    assert!(!dir.path().join("no").exists());
}

/// `index add` of a missing file fails before creating anything; `index remove` of a folder
/// removes every shape under it, as `index add` of a folder adds them; `index remove` on a
/// folder that is no index creates none.
#[test]
fn index_add_and_remove_treat_paths_alike() {
    let dir = tempfile::tempdir().expect("tempdir");
    let index = dir.path().join("index");
    let o = keycomp(&[
        "index",
        "add",
        s(&dir.path().join("nosuch.off")),
        "--index",
        s(&index),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nosuch.off"), "{}", stderr(&o));
    assert!(!index.exists(), "a failed add created the index");

    let o = keycomp(&["index", "remove", "x.off", "--index", s(&index)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!index.exists(), "remove created an index");

    let sub = dir.path().join("shapes/sub");
    std::fs::create_dir_all(&sub).expect("mkdir");
    small_off(&sub.join("a.off"));
    write_off(&synth::icosphere(3, 1.0), &sub.join("b.off")).expect("write");
    small_off(&dir.path().join("shapes/c.off"));
    let o = keycomp(&[
        "index",
        "add",
        s(&dir.path().join("shapes")),
        "--index",
        s(&index),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = keycomp(&["index", "remove", s(&sub), "--index", s(&index)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = common::stdout(&o);
    assert!(out.contains("removed 2 shapes (1 left)"), "{out}");
    let o = keycomp(&["index", "list", "--index", s(&index), "--json"]);
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let rows = rows.as_array().expect("array");
    assert_eq!(rows.len(), 1);
    assert!(rows[0]["path"].as_str().expect("path").ends_with("c.off"));
}

/// Seals `payload` as an index file of `kind` (the footer of `index/README.md`).
fn seal(mut payload: Vec<u8>, kind: u32) -> Vec<u8> {
    let len = payload.len() as u64;
    payload.extend_from_slice(&len.to_le_bytes());
    payload.extend_from_slice(&kind.to_le_bytes());
    payload.extend_from_slice(&keycomp_index::FORMAT_VERSION.to_le_bytes());
    let sum = xxhash_rust::xxh3::xxh3_64(&payload);
    payload.extend_from_slice(&sum.to_le_bytes());
    payload.extend_from_slice(&keycomp_index::FOOTER_MAGIC);
    payload
}

/// A MANIFEST whose checksums hold but whose profile length is huge (a buggy writer, a crafted
/// file): every command that reads it exits 2 with a message naming it, none panics or aborts.
#[test]
fn a_crafted_manifest_is_an_error_not_a_crash() {
    let dir = tempfile::tempdir().expect("tempdir");
    let index = dir.path().join("index");
    let mesh = small_off(&dir.path().join("m.off"));
    let o = keycomp(&["index", "add", s(&mesh), "--index", s(&index)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let manifest = index.join(keycomp_index::MANIFEST_NAME);
    let bytes = std::fs::read(&manifest).expect("read");
    let mut payload = bytes[..bytes.len() - keycomp_index::FOOTER_LEN].to_vec();
    // The profile is the payload's last field: its 8-byte length, then its bytes.
    let at = (0..payload.len() - 8)
        .rev()
        .find(|&i| {
            let n = u64::from_le_bytes(payload[i..i + 8].try_into().expect("8 bytes"));
            n as usize == payload.len() - i - 8
        })
        .expect("the profile's length field");
    payload[at..at + 8].copy_from_slice(&(1u64 << 46).to_le_bytes());
    std::fs::write(&manifest, seal(payload, 1)).expect("write");
    for args in [
        vec!["index", "verify", "--index", s(&index)],
        vec!["index", "list", "--index", s(&index)],
        vec!["query", s(&mesh), "--index", s(&index)],
        vec!["index", "add", s(&mesh), "--index", s(&index)],
    ] {
        let o = keycomp(&args);
        // verify reports its findings on stdout, the other commands on stderr
        let err = stderr(&o) + &common::stdout(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("MANIFEST") && err.contains("malformed"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

/// Negative numbers reach the option's own check instead of clap's "use '-- -1'" advice.
#[test]
fn negative_numbers_get_the_options_message() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mesh = small_off(&dir.path().join("m.off"));
    for args in [
        vec!["keypoints", s(&mesh), "--count", "-1"],
        vec!["query", s(&mesh), "-k", "-1"],
        vec!["detect", s(&mesh), "--n", "-3"],
    ] {
        let o = keycomp(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(err.contains("at least 1"), "{args:?}: {err}");
        assert!(!err.contains("-- -"), "{args:?}: {err}");
    }
    for args in [
        vec!["detect", s(&mesh), "--r", "0"],
        vec!["detect", s(&mesh), "--n", "0"],
    ] {
        let o = keycomp(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: accepted");
    }
}

/// A demo with impossible options fails before creating its folders.
#[test]
fn a_failed_demo_leaves_nothing_behind() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("demo-out");
    let index = dir.path().join("demo-index");
    let o = keycomp(&[
        "demo",
        "--vertices",
        "10",
        "--out",
        s(&out),
        "--index",
        s(&index),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--vertices"), "{}", stderr(&o));
    assert!(!out.exists() && !index.exists());
}

/// An error whose message already holds its cause says it once.
#[test]
fn causes_are_not_repeated() {
    let dir = tempfile::tempdir().expect("tempdir");
    small_off(&dir.path().join("a.off"));
    small_off(&dir.path().join("b.off"));
    let o = keycomp(&[
        "bench",
        "retrieval",
        "--collection",
        s(dir.path()),
        "--labels",
        s(&dir.path().join("nosuch.csv")),
        "--out",
        s(&dir.path().join("out")),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
}
