//! The cache of detections: records keyed by the file's content, the detection parameters, the
//! role (shape or query) and the running executable's bytes (see the parent module's docs).

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::Result;
use keycomp::{Profile, Role, records_as};
use keycomp_describe::DIM;
use keycomp_index::{ContentHash, ShapeRecord};

use crate::output;

/// Records cached by content, detection parameters and executable (see the module docs).
pub(super) struct RecordCache {
    pub(super) dir: Option<PathBuf>,
    pub(super) salt: String,
}

impl RecordCache {
    pub(super) fn new(dir: PathBuf, params: &Profile) -> RecordCache {
        let exe = std::env::current_exe()
            .ok()
            .and_then(|p| fs::read(p).ok())
            .map(|b| xxhash_rust::xxh3::xxh3_128(&b));
        // A cache that cannot be made only costs time.
        let made = fs::create_dir_all(&dir).is_ok();
        match exe {
            Some(h) if made => RecordCache {
                dir: Some(dir),
                salt: format!(
                    "{h:032x}|{}",
                    serde_json::to_string(params).unwrap_or_default()
                ),
            },
            _ => {
                eprintln!(
                    "warning: cannot read the running executable or create {}; detections are \
                     not cached",
                    dir.display()
                );
                RecordCache {
                    dir: None,
                    salt: String::new(),
                }
            }
        }
    }

    pub(super) fn path(&self, hash: &ContentHash, role: Role) -> Option<PathBuf> {
        let dir = self.dir.as_ref()?;
        let key = xxhash_rust::xxh3::xxh3_128(format!("{hash}|{role:?}|{}", self.salt).as_bytes());
        Some(dir.join(format!("{key:032x}.json")))
    }

    /// The records of `path` (content `hash`) analysed as `role` (one per description), from
    /// the cache or computed (and stored).
    pub(super) fn records(
        &self,
        path: &Path,
        hash: ContentHash,
        params: &Profile,
        role: Role,
    ) -> Result<(Vec<ShapeRecord<DIM>>, bool)> {
        let entry = self.path(&hash, role);
        let cached = entry
            .as_ref()
            .and_then(|e| fs::read(e).ok())
            .and_then(|b| serde_json::from_slice::<Vec<ShapeRecord<DIM>>>(&b).ok())
            .filter(|rs| !rs.is_empty() && rs.iter().all(|r| r.content_hash == hash));
        if let Some(mut rs) = cached {
            for r in &mut rs {
                r.path = path.to_path_buf();
                r.canonical_path = keycomp_index::canonical_path(path);
            }
            return Ok((rs, true));
        }
        let r = records_as(path, hash, params, role)?;
        if let (Some(e), Ok(bytes)) = (entry, serde_json::to_vec(&r)) {
            // a cache that cannot be written only costs time
            let _ = output::write_bytes(&e, &bytes);
        }
        Ok((r, false))
    }
}
