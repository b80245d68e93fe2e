//! Finding the null shapes and their real poses in a data folder (TOSCA, KIDS and FAUST
//! layouts, or a flat folder of meshes); see *Data* in the [module docs](super).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use keycomp_mesh::Format;
use serde::Serialize;

use crate::error::BenchError;
use crate::transform::MAX_STRENGTH;

/// The name of the real-pose transformation.
pub const ISOMETRY: &str = "isometry";

/// A real pose of a null shape, with the same vertex numbering.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PoseSpec {
    /// Isometry strength (1..=5).
    pub strength: u8,
    /// The pose's mesh file.
    pub path: PathBuf,
}

/// A null shape and its real poses.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct NullSpec {
    /// Short name (`cat0`, `kids-0001`, or the file stem).
    pub name: String,
    /// Mesh file.
    pub path: PathBuf,
    /// Isometry transformations (possibly none).
    pub poses: Vec<PoseSpec>,
}

fn data_error(path: &Path, message: impl Into<String>) -> BenchError {
    BenchError::Data {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Mesh files directly in `dir` (by extension), sorted by name.
fn mesh_files(dir: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let entries = std::fs::read_dir(dir).map_err(|source| BenchError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::new();
    for e in entries {
        let e = e.map_err(|source| BenchError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = e.path();
        let is_mesh = path
            .extension()
            .and_then(|x| x.to_str())
            .is_some_and(|x| Format::from_extension(x).is_some());
        if is_mesh && path.is_file() {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

pub(super) fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Finds the null shapes (and their poses) in `dir`; see the [module docs](super) for the
/// layouts.
///
/// Errors: the folder cannot be read, or it holds no null shape.
pub fn discover(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    if !dir.is_dir() {
        return Err(data_error(
            dir,
            "no such folder: pass --data DIR with the null shapes (the default is ../shared/data, \
             relative to the current folder)",
        ));
    }
    let tosca = dir.join("tosca");
    let kids = dir.join("kids");
    let faust = dir.join("faust");
    let mut nulls = Vec::new();
    if tosca.is_dir() || kids.is_dir() {
        if tosca.is_dir() {
            nulls.extend(discover_tosca(&tosca)?);
        }
        if kids.is_dir() {
            nulls.extend(discover_kids(&kids)?);
        }
        if faust.is_dir() {
            nulls.extend(discover_faust(&faust)?);
        }
    } else {
        for path in mesh_files(dir)? {
            nulls.push(NullSpec {
                name: stem(&path),
                path,
                poses: Vec::new(),
            });
        }
    }
    if nulls.is_empty() {
        return Err(data_error(
            dir,
            "no null shape found: expected mesh files (.off, .obj, .ply, .stl), or tosca/ and \
             kids/ subfolders laid out as in ../shared/data",
        ));
    }
    Ok(nulls)
}

/// TOSCA: `<class><pose>.<ext>`; pose 0 is the null shape.
fn discover_tosca(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    let mut classes: BTreeMap<String, Vec<(u32, PathBuf)>> = BTreeMap::new();
    for path in mesh_files(dir)? {
        let s = stem(&path);
        let digits = s.len() - s.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let (class, number) = s.split_at(s.len() - digits);
        if class.is_empty() {
            continue;
        }
        if let Ok(n) = number.parse::<u32>() {
            classes.entry(class.to_owned()).or_default().push((n, path));
        }
    }
    let mut out = Vec::new();
    for (class, mut poses) in classes {
        poses.sort();
        let Some(pos) = poses.iter().position(|(n, _)| *n == 0) else {
            continue;
        };
        let (_, null) = poses.remove(pos);
        out.push(NullSpec {
            name: format!("{class}0"),
            path: null,
            poses: poses
                .into_iter()
                .take(usize::from(MAX_STRENGTH))
                .zip(1..)
                .map(|((_, path), strength)| PoseSpec { strength, path })
                .collect(),
        });
    }
    Ok(out)
}

/// KIDS / SHREC'10 names: `<id>.null.0.<ext>` and `<id>.isometry.<k>.<ext>`.
fn discover_kids(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    let files = mesh_files(dir)?;
    let mut out = Vec::new();
    for path in &files {
        let s = stem(path);
        let Some(id) = s.strip_suffix(".null.0") else {
            continue;
        };
        let mut poses = Vec::new();
        for k in 1..=MAX_STRENGTH {
            let want = format!("{id}.isometry.{k}");
            if let Some(p) = files.iter().find(|p| stem(p) == want) {
                poses.push(PoseSpec {
                    strength: k,
                    path: p.clone(),
                });
            }
        }
        out.push(NullSpec {
            name: format!("kids-{id}"),
            path: path.clone(),
            poses,
        });
    }
    Ok(out)
}

/// FAUST registrations `tr_reg_NNN` (subject NNN / 10, pose NNN % 10, shared vertex
/// numbering): subject 0's pose 0 (`tr_reg_000`) is the null shape and its poses 1..=5
/// (`tr_reg_001`..`tr_reg_005`) are isometries of strengths 1..=5 — "poses of one subject".
fn discover_faust(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    let files = mesh_files(dir)?;
    let find = |n: u32| files.iter().find(|p| stem(p) == format!("tr_reg_{n:03}"));
    let Some(null) = find(0) else {
        return Ok(Vec::new());
    };
    let poses = (1..=MAX_STRENGTH)
        .filter_map(|k| {
            find(u32::from(k)).map(|p| PoseSpec {
                strength: k,
                path: p.clone(),
            })
        })
        .collect();
    Ok(vec![NullSpec {
        name: "faust-000".to_string(),
        path: null.clone(),
        poses,
    }])
}
