//! [`verify`]: a read-only health check of an index directory.
//!
//! Checks the manifest and every segment it lists (footer, checksum, version, length and
//! checksum against the manifest, full decode and validation of every record), that every
//! tombstone names a stored shape and that no canonical path is live twice; lists the files
//! that no manifest references (harmless leftovers of interrupted writes, deleted by the next
//! successful write or [`crate::IndexWriter::remove_leftovers`]). It modifies nothing.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use crate::dir::{MANIFEST_NAME, leftover_files, parse_segment_file_name, segment_file_name};
use crate::error::{CorruptKind, IndexError, Result};
use crate::file::{self, KIND_SEGMENT};
use crate::manifest::Manifest;
use crate::segment;
use crate::version::FORMAT_VERSION;

/// What [`verify`] found.
#[derive(Debug)]
pub struct VerifyReport {
    /// The index directory.
    pub dir: PathBuf,
    /// Generation of the manifest, if it could be read.
    pub generation: Option<u64>,
    /// Segment files listed in the manifest.
    pub segments_listed: usize,
    /// Listed segments that passed every check.
    pub segments_ok: usize,
    /// Live shapes in the segments that passed.
    pub shapes: usize,
    /// Live components in the segments that passed.
    pub components: usize,
    /// Every problem found; each error names its file. Empty for a healthy index.
    pub problems: Vec<IndexError>,
    /// Files not referenced by the manifest (temp files, segments of interrupted adds). Not a
    /// problem: readers ignore them and the next write deletes them.
    pub leftovers: Vec<PathBuf>,
}

impl VerifyReport {
    /// Whether no problem was found (leftovers do not count).
    pub fn is_ok(&self) -> bool {
        self.problems.is_empty()
    }
}

/// Verifies the index at `dir` for descriptors of length `D` without modifying anything.
///
/// Returns `Err` only when `dir` is not an index at all ([`IndexError::NotAnIndex`]) or cannot
/// be listed; every other finding goes into [`VerifyReport::problems`].
///
/// A writer may commit while `verify` reads: a segment listed in the manifest it read can be
/// deleted by a later generation. When a listed segment is missing and the manifest has moved
/// on meanwhile, the check starts again on the new manifest (like [`crate::IndexReader::open`]),
/// so a concurrent write is not reported as damage.
pub fn verify<const D: usize>(dir: impl AsRef<Path>) -> Result<VerifyReport> {
    let dir = dir.as_ref();
    let mut attempt = 0;
    loop {
        attempt += 1;
        let report = verify_once::<D>(dir)?;
        let missing = report
            .problems
            .iter()
            .any(|p| matches!(p, IndexError::MissingSegment { .. }));
        if !missing || attempt >= crate::reader::OPEN_ATTEMPTS {
            return Ok(report);
        }
        let moved = Manifest::read(dir, Some(segment::dim_u32::<D>()))
            .is_ok_and(|m| Some(m.generation) != report.generation);
        if !moved {
            return Ok(report);
        }
    }
}

fn verify_once<const D: usize>(dir: &Path) -> Result<VerifyReport> {
    if !dir.join(MANIFEST_NAME).exists() {
        return Err(IndexError::NotAnIndex {
            dir: dir.to_path_buf(),
        });
    }
    let mut report = VerifyReport {
        dir: dir.to_path_buf(),
        generation: None,
        segments_listed: 0,
        segments_ok: 0,
        shapes: 0,
        components: 0,
        problems: Vec::new(),
        leftovers: Vec::new(),
    };
    let manifest = match Manifest::read(dir, Some(segment::dim_u32::<D>())) {
        Ok(m) => m,
        Err(e) => {
            report.problems.push(e);
            // Without a manifest, at least say which segment files are intact.
            let rd =
                std::fs::read_dir(dir).map_err(|e| IndexError::io("could not list", dir, e))?;
            let mut names: Vec<PathBuf> = rd
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| parse_segment_file_name(n).is_some())
                })
                .collect();
            names.sort();
            for p in names {
                let checked = file::read_all(&p)
                    .map_err(|e| IndexError::io("could not read", &p, e))
                    .and_then(|b| file::unseal(&p, b, KIND_SEGMENT, FORMAT_VERSION).map(|_| ()));
                if let Err(e) = checked {
                    report.problems.push(e);
                }
            }
            return Ok(report);
        }
    };
    report.generation = Some(manifest.generation);
    report.segments_listed = manifest.segments.len();
    let manifest_path = dir.join(MANIFEST_NAME);
    let mut stored_ids = HashSet::new();
    let mut live_paths: HashMap<PathBuf, u64> = HashMap::new();
    for entry in &manifest.segments {
        match segment::read::<D>(dir, &manifest, entry) {
            Ok(seg) => {
                report.segments_ok += 1;
                for (c, r) in seg.head.catalogue.iter().zip(&seg.records) {
                    if !stored_ids.insert(c.id) {
                        report.problems.push(IndexError::corrupt(
                            dir.join(segment_file_name(entry.number)),
                            CorruptKind::Malformed(format!(
                                "shape id {} is stored in an earlier segment too",
                                c.id
                            )),
                        ));
                    }
                    if manifest.is_tombstoned(c.id) {
                        continue;
                    }
                    report.shapes += 1;
                    report.components += r.components.len();
                    *live_paths.entry(r.canonical_path.clone()).or_default() += 1;
                }
            }
            Err(e) => report.problems.push(e),
        }
    }
    if report.segments_ok == report.segments_listed {
        if let Some(t) = manifest.tombstones.iter().find(|t| !stored_ids.contains(t)) {
            report.problems.push(IndexError::corrupt(
                &manifest_path,
                CorruptKind::Malformed(format!("tombstone {t} names no stored shape")),
            ));
        }
        let mut dups: Vec<&PathBuf> = live_paths
            .iter()
            .filter(|(_, n)| **n > 1)
            .map(|(p, _)| p)
            .collect();
        dups.sort();
        if let Some(p) = dups.first() {
            report.problems.push(IndexError::corrupt(
                &manifest_path,
                CorruptKind::Malformed(format!(
                    "{} live shapes share the path {}",
                    live_paths.get(*p).copied().unwrap_or(0),
                    p.display()
                )),
            ));
        }
    }
    let listed: HashSet<u64> = manifest.segments.iter().map(|s| s.number).collect();
    report.leftovers = leftover_files(dir, &listed)?;
    Ok(report)
}
