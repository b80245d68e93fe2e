//! The cache of detections: records keyed by the file's content, the detection parameters, the
//! role (shape or query) and the running program, in a [`CacheFolder`] with the benchmarks' one
//! key and invalidation rule (see [`keycomp_bench::cache`]).

use std::path::{Path, PathBuf};

use anyhow::Result;
use keycomp::{Profile, Role, records_as};
use keycomp_bench::cache::{CacheFolder, Lookup, key_hasher, program_hash};
use keycomp_describe::DIM;
use keycomp_index::{ContentHash, ShapeRecord};

/// Records cached by content, detection parameters, role and program (see the module docs).
pub(super) struct RecordCache {
    /// `None` when nothing can be cached (the folder cannot be made or the program is unknown).
    folder: Option<CacheFolder>,
    /// The detection parameters' JSON, part of every key.
    params: String,
}

impl RecordCache {
    pub(super) fn new(dir: PathBuf, params: &Profile) -> RecordCache {
        // A cache that cannot be made only costs time.
        let made = std::fs::create_dir_all(&dir).is_ok();
        let folder = if made && program_hash().is_some() {
            Some(CacheFolder::new(dir))
        } else {
            eprintln!(
                "warning: cannot read the running executable or create {}; detections are not \
                 cached",
                dir.display()
            );
            None
        };
        RecordCache {
            folder,
            params: serde_json::to_string(params).unwrap_or_default(),
        }
    }

    fn key(&self, hash: &ContentHash, role: Role) -> Option<u128> {
        let mut h = key_hasher(b"keycomp-records")?;
        h.update(format!("{hash}|{role:?}|{}", self.params).as_bytes());
        Some(h.digest128())
    }

    /// The records of `path` (content `hash`) analysed as `role` (one per description), from
    /// the cache or computed (and stored). The flag says whether they came from the cache.
    pub(super) fn records(
        &self,
        path: &Path,
        hash: ContentHash,
        params: &Profile,
        role: Role,
    ) -> Result<(Vec<ShapeRecord<DIM>>, bool)> {
        let entry = self
            .folder
            .as_ref()
            .and_then(|f| self.key(&hash, role).map(|k| (f, k)));
        let cached = entry.and_then(|(f, k)| {
            let valid = |b: &[u8]| {
                serde_json::from_slice::<Vec<ShapeRecord<DIM>>>(b)
                    .ok()
                    .filter(|rs| !rs.is_empty() && rs.iter().all(|r| r.content_hash == hash))
            };
            match f.read(k, "json", valid) {
                Lookup::Hit(rs) => Some(rs),
                Lookup::Miss | Lookup::Corrupt => None,
            }
        });
        if let Some(mut rs) = cached {
            for r in &mut rs {
                r.path = path.to_path_buf();
                r.canonical_path = keycomp_index::canonical_path(path);
            }
            return Ok((rs, true));
        }
        let r = records_as(path, hash, params, role)?;
        if let (Some((f, k)), Ok(bytes)) = (entry, serde_json::to_vec(&r)) {
            // a cache that cannot be written only costs time
            let _ = f.write(k, "json", &bytes);
        }
        Ok((r, false))
    }
}
