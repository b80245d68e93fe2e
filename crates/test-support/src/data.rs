//! Where the workspace and the shared research meshes are.
//!
//! This crate is `crates/test-support`, so the workspace root is two folders above its
//! `CARGO_MANIFEST_DIR`, and the shared meshes are [`SHARED_DATA`] from there.

use std::path::{Path, PathBuf};

/// The shared research meshes, relative to the workspace root: the folder `shared/data` next
/// to the workspace (TOSCA, KIDS, FAUST, the models and scans). Never copied into the
/// workspace nor committed.
pub const SHARED_DATA: &str = "../shared/data";

/// The workspace root: the folder of the root `Cargo.toml`.
pub fn workspace_root() -> &'static Path {
    let manifest_dir: &'static Path = Path::new(env!("CARGO_MANIFEST_DIR"));
    // crates/test-support -> crates -> the root
    manifest_dir.ancestors().nth(2).unwrap_or(manifest_dir)
}

/// `path` taken from the workspace root when it is relative (an absolute path is returned as
/// it is). For a bench's or a harness's path argument: `cargo bench` runs a bench in its
/// package's folder, and the documented command lines give paths from the root
/// (`cargo bench -p keycomp-bench --bench transform_times -- ../shared/data/kids/0001.null.0.off`).
pub fn workspace_path(path: impl AsRef<Path>) -> PathBuf {
    workspace_root().join(path)
}

/// The shared meshes' folder (`sub` empty) or the file or folder `sub` inside it, when it
/// exists; otherwise `None`, after printing `skipping: PATH not found` on standard error.
///
/// A test that needs real meshes starts with `let Some(…) = shared_data(…) else { return };`,
/// so that it passes, with the message, on a machine without the data:
///
/// ```
/// use keycomp_test_support::shared_data;
///
/// let Some(cat) = shared_data("tosca/cat0.off") else {
///     return; // "skipping: …/shared/data/tosca/cat0.off not found (…)"
/// };
/// assert!(cat.is_file());
/// ```
pub fn shared_data(sub: impl AsRef<Path>) -> Option<PathBuf> {
    let sub = sub.as_ref();
    let root = workspace_path(SHARED_DATA);
    let path = if sub.as_os_str().is_empty() {
        root
    } else {
        root.join(sub)
    };
    if path.exists() {
        Some(path)
    } else {
        eprintln!(
            "skipping: {} not found (the shared meshes are read from {SHARED_DATA}, next to the workspace)",
            path.display()
        );
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_workspace_root_holds_the_workspace_manifest() {
        let manifest = std::fs::read_to_string(workspace_root().join("Cargo.toml"))
            .expect("the root Cargo.toml reads");
        assert!(manifest.contains("[workspace]"), "{manifest}");
        assert!(workspace_path("crates/test-support/src/data.rs").is_file());
    }

    #[test]
    fn absolute_paths_are_kept() {
        let abs = std::env::temp_dir();
        assert!(abs.is_absolute());
        assert_eq!(workspace_path(&abs), abs);
    }

    #[test]
    fn shared_data_is_the_folder_when_present_and_none_for_what_is_absent() {
        let root = workspace_path(SHARED_DATA);
        assert_eq!(shared_data(""), root.is_dir().then(|| root.clone()));
        assert_eq!(shared_data("no such folder/mesh.off"), None);
    }
}
