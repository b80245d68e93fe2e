//! [`IndexWriter`]: adds, replaces and removes shapes; compacts; cleans leftovers.
//!
//! Commit protocol of every change (add, remove, compact), while holding the exclusive lock
//! on `LOCK`:
//! 1. write each new segment atomically (temp file, fsync, rename, fsync directory);
//! 2. write the new `MANIFEST` (generation + 1) atomically the same way — this rename is the
//!    commit point;
//! 3. delete files that no manifest references any more (leftover temp files, segments of a
//!    killed add, segments whose shapes were all removed).
//!
//! A crash before step 2's rename leaves the old manifest in place, which references only old,
//! complete files: the index is as it was. A crash after it leaves the new manifest, whose
//! files were all made durable in step 1: the index is as after. Step 3 only ever deletes
//! files the current manifest does not list, so it is safe to interrupt and to repeat.

use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::path::{Path, PathBuf};

use crate::dir::{
    LOCK_NAME, MANIFEST_NAME, leftover_files, parse_segment_file_name, segment_file_name,
};
use crate::error::{IndexError, Result};
use crate::file;
use crate::manifest::{Manifest, SegmentEntry};
use crate::reader::IndexReader;
use crate::record::{ContentHash, ShapeId, ShapeRecord, canonical_path};
use crate::segment;

/// What happened to one record given to [`IndexWriter::add_batch`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum AddOutcome {
    /// A new shape, stored under this id.
    Added(ShapeId),
    /// The canonical path was indexed with another content hash; the old shape was removed
    /// and the record stored under a new id.
    Replaced {
        /// Id of the removed shape.
        old: ShapeId,
        /// Id of the new shape.
        new: ShapeId,
    },
    /// The canonical path is already indexed with the same content hash (or appears again
    /// later in the same batch); nothing was stored.
    Skipped,
}

/// Result of [`IndexWriter::add_batch`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AddSummary {
    /// Records stored as new shapes.
    pub added: usize,
    /// Records that replaced an indexed shape with a different content hash.
    pub replaced: usize,
    /// Records skipped (same canonical path and content hash already indexed).
    pub skipped: usize,
    /// One outcome per input record, in input order.
    pub outcomes: Vec<AddOutcome>,
    /// Generation of the manifest after the call (unchanged if nothing was stored).
    pub generation: u64,
    /// The segment file written, if any.
    pub segment: Option<PathBuf>,
}

/// Result of [`IndexWriter::merge`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MergeSummary {
    /// Live shapes read from the sources.
    pub read: usize,
    /// Shapes stored in the destination.
    pub added: usize,
    /// Shapes already there (same canonical path and content hash in the destination or an
    /// earlier source), stored once.
    pub duplicates: usize,
    /// Generation of the destination's manifest after the merge.
    pub generation: u64,
}

#[derive(Debug, Clone, Copy)]
struct Live {
    id: ShapeId,
    hash: ContentHash,
    segment: u64,
}

/// Exclusive writer of an index directory. Holds an advisory lock on `DIR/LOCK` for its
/// whole lifetime, so writers in other processes (or threads) wait for it; readers are not
/// affected.
#[derive(Debug)]
pub struct IndexWriter<const D: usize> {
    dir: PathBuf,
    _lock: File,
    manifest: Manifest,
    /// Live shapes by canonical path.
    live: HashMap<String, Live>,
    /// Live shape count per segment number.
    live_per_segment: HashMap<u64, u64>,
}

impl<const D: usize> IndexWriter<D> {
    /// The index's profile: how its descriptors were made (empty when none is recorded; see
    /// [`IndexWriter::ensure_profile`]).
    pub fn profile(&self) -> &str {
        &self.manifest.profile
    }

    /// Makes sure the index holds descriptors made as `profile` says (free text, e.g. the
    /// descriptor version and detection parameters; not empty). An index without shapes takes
    /// the profile (written with the next commit); an index whose profile equals it is
    /// accepted; any other, including a format-1 index with shapes (no profile), gives
    /// [`IndexError::ProfileMismatch`] and nothing is changed.
    pub fn ensure_profile(&mut self, profile: &str) -> Result<()> {
        if profile.is_empty() {
            return Err(IndexError::InvalidRecord {
                path: self.dir.clone(),
                reason: "the profile must not be empty".into(),
            });
        }
        if self.manifest.profile == profile {
            return Ok(());
        }
        if self.live.is_empty() {
            self.manifest.profile = profile.to_string();
            return Ok(());
        }
        Err(IndexError::ProfileMismatch {
            dir: self.dir.clone(),
            found: self.manifest.profile.clone(),
            requested: profile.to_string(),
        })
    }

    /// Opens the index at `dir` for writing, creating the directory and an empty index if
    /// there is none. Blocks while another writer holds the lock.
    ///
    /// Checks the manifest and every segment's checksum (a damaged index is not written to),
    /// then deletes leftovers of interrupted writes.
    pub fn create_or_open(dir: impl AsRef<Path>) -> Result<Self> {
        Self::open_impl(dir.as_ref(), true)
    }

    /// Like [`IndexWriter::create_or_open`] but fails with [`IndexError::Locked`] instead of
    /// waiting when another writer holds the lock.
    pub fn try_create_or_open(dir: impl AsRef<Path>) -> Result<Self> {
        Self::open_impl(dir.as_ref(), false)
    }

    fn open_impl(dir: &Path, wait: bool) -> Result<Self> {
        fs::create_dir_all(dir).map_err(|e| IndexError::io("could not create", dir, e))?;
        let lock_path = dir.join(LOCK_NAME);
        let lock = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&lock_path)
            .map_err(|e| IndexError::io("could not open lock file", &lock_path, e))?;
        if wait {
            fs4::FileExt::lock(&lock)
                .map_err(|e| IndexError::io("could not lock", &lock_path, e))?;
        } else {
            match fs4::FileExt::try_lock(&lock) {
                Ok(()) => {}
                Err(fs4::TryLockError::WouldBlock) => {
                    return Err(IndexError::Locked {
                        dir: dir.to_path_buf(),
                        lock: lock_path,
                    });
                }
                Err(fs4::TryLockError::Error(e)) => {
                    return Err(IndexError::io("could not lock", &lock_path, e));
                }
            }
        }
        let dim = segment::dim_u32::<D>();
        let manifest = match Manifest::read(dir, Some(dim)) {
            Ok(m) => m,
            Err(IndexError::NotAnIndex { .. }) => {
                // Never start an empty index over segments whose manifest was lost: the
                // leftover cleanup would delete them.
                let orphans = leftover_files(dir, &std::collections::HashSet::new())?
                    .iter()
                    .filter(|p| {
                        p.file_name()
                            .and_then(|n| n.to_str())
                            .is_some_and(|n| parse_segment_file_name(n).is_some())
                    })
                    .count();
                if orphans > 0 {
                    return Err(IndexError::corrupt(
                        dir.join(MANIFEST_NAME),
                        crate::error::CorruptKind::MissingManifest { segments: orphans },
                    ));
                }
                let m = Manifest::empty(dim);
                m.write(dir)?;
                m
            }
            Err(e) => return Err(e),
        };
        let mut live = HashMap::new();
        let mut live_per_segment = HashMap::new();
        for entry in &manifest.segments {
            let head = segment::read_head(dir, &manifest, entry)?;
            let mut count = 0;
            for c in head.catalogue {
                if manifest.is_tombstoned(c.id) {
                    continue;
                }
                count += 1;
                live.insert(
                    c.canonical_path,
                    Live {
                        id: c.id,
                        hash: c.content_hash,
                        segment: entry.number,
                    },
                );
            }
            live_per_segment.insert(entry.number, count);
        }
        let writer = IndexWriter {
            dir: dir.to_path_buf(),
            _lock: lock,
            manifest,
            live,
            live_per_segment,
        };
        writer.remove_leftovers()?;
        Ok(writer)
    }

    /// The index directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Generation of the current manifest.
    pub fn generation(&self) -> u64 {
        self.manifest.generation
    }

    /// Number of live shapes.
    pub fn len(&self) -> usize {
        self.live.len()
    }

    /// Whether the index holds no live shape.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }

    /// Canonical paths of the live shapes, in no particular order.
    pub fn canonical_paths(&self) -> impl Iterator<Item = &Path> {
        self.live.keys().map(Path::new)
    }

    /// Id and content hash of the live shape with this canonical path, if any. Lets a caller
    /// skip describing a file whose hash is already indexed.
    pub fn lookup(&self, canonical: &Path) -> Option<(ShapeId, ContentHash)> {
        canonical
            .to_str()
            .and_then(|k| self.live.get(k))
            .map(|l| (l.id, l.hash))
    }

    /// Merges the live shapes of `sources` (indexes built independently, e.g. shards of one
    /// collection) into this index, in one commit: readers see all of them or none.
    ///
    /// Every source must have this index's profile (an empty destination takes the first
    /// source's); otherwise [`IndexError::MergeProfile`] names the source. Shapes are
    /// identified by canonical path: one already in the destination or in an earlier source
    /// with the same content hash is stored once; with another hash, the merge stops with
    /// [`IndexError::MergeConflict`] naming both indexes. On any error nothing is written.
    /// Shapes get new ids here, in source order, then each source's id order.
    pub fn merge(&mut self, sources: &[IndexReader<D>]) -> Result<MergeSummary> {
        let mut profile: Option<(String, PathBuf)> = if self.live.is_empty() {
            None
        } else {
            Some((self.manifest.profile.clone(), self.dir.clone()))
        };
        for src in sources {
            match &profile {
                None => profile = Some((src.profile().to_string(), src.dir().to_path_buf())),
                Some((p, dir)) if p != src.profile() => {
                    return Err(IndexError::MergeProfile {
                        source_dir: src.dir().to_path_buf(),
                        dest: dir.clone(),
                        detail: profile_difference(p, src.profile()),
                    });
                }
                Some(_) => {}
            }
        }
        // Where each canonical path was first seen: (content hash, index dir).
        let mut seen: HashMap<PathBuf, (ContentHash, &Path)> = HashMap::new();
        let mut batch = Vec::new();
        let (mut read, mut duplicates) = (0, 0);
        for src in sources {
            for shape in src.shapes()? {
                read += 1;
                let r = &shape.record;
                let key = r.canonical_path.as_path();
                let first = match self.lookup(key) {
                    Some((_, hash)) => Some((hash, self.dir.as_path())),
                    None => seen.get(key).copied(),
                };
                match first {
                    Some((hash, _)) if hash == r.content_hash => duplicates += 1,
                    Some((hash, dir)) => {
                        return Err(IndexError::MergeConflict {
                            path: key.to_path_buf(),
                            first: dir.to_path_buf(),
                            first_hash: hash.to_hex(),
                            second: src.dir().to_path_buf(),
                            second_hash: r.content_hash.to_hex(),
                        });
                    }
                    None => {
                        seen.insert(key.to_path_buf(), (r.content_hash, src.dir()));
                        batch.push((**r).clone());
                    }
                }
            }
        }
        if let Some((p, _)) = profile
            && !p.is_empty()
        {
            self.ensure_profile(&p)?;
        }
        let summary = self.add_batch(batch)?;
        Ok(MergeSummary {
            read,
            added: summary.added,
            duplicates,
            generation: summary.generation,
        })
    }

    /// Adds a batch of records as one new segment and commits it (one manifest update).
    ///
    /// Shapes are identified by `canonical_path`: a record whose canonical path is indexed with
    /// the same content hash is skipped; with another hash it replaces the indexed shape (the
    /// old one is tombstoned in the same commit). If a canonical path appears several times in
    /// the batch, the last occurrence wins. Every record is validated first
    /// ([`ShapeRecord::validate`]); if one is invalid nothing is written.
    ///
    /// On success the batch is durable. Call it every few dozen shapes so that a long indexing
    /// run persists its progress.
    pub fn add_batch(&mut self, records: Vec<ShapeRecord<D>>) -> Result<AddSummary> {
        for r in &records {
            r.validate()?;
        }
        let n = records.len();
        // Last occurrence of each canonical path wins within the batch.
        let mut last: HashMap<&str, usize> = HashMap::new();
        for (i, r) in records.iter().enumerate() {
            if let Some(k) = r.canonical_path.to_str() {
                last.insert(k, i);
            }
        }
        let mut keep = vec![false; n];
        let mut outcomes = vec![AddOutcome::Skipped; n];
        let mut new_tombstones = Vec::new();
        let mut next_id = self.manifest.next_shape_id;
        let mut new_ids = Vec::new();
        let mut new_records = Vec::new();
        let mut replaced_old: Vec<(usize, ShapeId)> = Vec::new();
        for (i, r) in records.iter().enumerate() {
            let key = r.canonical_path.to_str().unwrap_or_default();
            if last.get(key) != Some(&i) {
                continue;
            }
            match self.live.get(key) {
                Some(l) if l.hash == r.content_hash => continue,
                Some(l) => {
                    new_tombstones.push((l.id, l.segment));
                    replaced_old.push((i, l.id));
                }
                None => {}
            }
            keep[i] = true;
        }
        for (i, r) in records.into_iter().enumerate() {
            if !keep[i] {
                continue;
            }
            let id = ShapeId(next_id);
            next_id += 1;
            outcomes[i] = AddOutcome::Added(id);
            new_ids.push(id);
            new_records.push(r);
        }
        for (i, old) in replaced_old {
            if let AddOutcome::Added(new) = outcomes[i] {
                outcomes[i] = AddOutcome::Replaced { old, new };
            }
        }
        let added = outcomes
            .iter()
            .filter(|o| matches!(o, AddOutcome::Added(_)))
            .count();
        let replaced = outcomes
            .iter()
            .filter(|o| matches!(o, AddOutcome::Replaced { .. }))
            .count();
        let skipped = n - added - replaced;
        if new_records.is_empty() {
            return Ok(AddSummary {
                added,
                replaced,
                skipped,
                outcomes,
                generation: self.manifest.generation,
                segment: None,
            });
        }

        // 1. The new segment, durable before the manifest mentions it.
        let number = self.manifest.next_segment;
        let (bytes, checksum) = segment::encode(number, &new_ids, &new_records)?;
        let seg_path = file::write_atomic(&self.dir, &segment_file_name(number), &bytes)?;
        let entry = SegmentEntry {
            number,
            len: bytes.len() as u64,
            checksum,
            shapes: new_records.len() as u64,
            components: new_records.iter().map(|r| r.components.len() as u64).sum(),
        };

        // 2. The new manifest.
        let mut m = self.manifest.clone();
        m.next_segment = number + 1;
        m.next_shape_id = next_id;
        m.segments.push(entry);
        let mut live_per_segment = self.live_per_segment.clone();
        live_per_segment.insert(number, new_records.len() as u64);
        let mut live_changes: Vec<(String, Option<Live>)> = Vec::new();
        for (old, seg) in new_tombstones {
            if let Some(c) = live_per_segment.get_mut(&seg) {
                *c = c.saturating_sub(1);
            }
            m.tombstones.push(old);
        }
        for (id, r) in new_ids.iter().zip(&new_records) {
            live_changes.push((
                r.canonical_path.to_string_lossy().into_owned(),
                Some(Live {
                    id: *id,
                    hash: r.content_hash,
                    segment: number,
                }),
            ));
        }
        self.commit(m, live_per_segment, live_changes)?;
        Ok(AddSummary {
            added,
            replaced,
            skipped,
            outcomes,
            generation: self.manifest.generation,
            segment: Some(seg_path),
        })
    }

    /// Writes `m` (with generation + 1, tombstones normalised, fully dead segments dropped) as
    /// the new manifest, then updates the in-memory state and removes leftovers.
    fn commit(
        &mut self,
        mut m: Manifest,
        mut live_per_segment: HashMap<u64, u64>,
        live_changes: Vec<(String, Option<Live>)>,
    ) -> Result<()> {
        m.generation = self.manifest.generation + 1;
        m.tombstones.sort_unstable();
        m.tombstones.dedup();
        // Drop segments with no live shape, and their tombstones.
        let dead: Vec<u64> = m
            .segments
            .iter()
            .filter(|s| live_per_segment.get(&s.number).copied().unwrap_or(0) == 0)
            .map(|s| s.number)
            .collect();
        if !dead.is_empty() {
            // Tombstones of a dropped segment are the ids stored in it; read their heads to
            // find them (the files are still there).
            let mut dead_ids = Vec::new();
            for s in m.segments.iter().filter(|s| dead.contains(&s.number)) {
                let head = segment::read_head(&self.dir, &m, s)?;
                dead_ids.extend(head.catalogue.into_iter().map(|c| c.id));
            }
            dead_ids.sort_unstable();
            m.tombstones.retain(|t| dead_ids.binary_search(t).is_err());
            m.segments.retain(|s| !dead.contains(&s.number));
            for d in &dead {
                live_per_segment.remove(d);
            }
        }
        m.write(&self.dir)?;
        self.manifest = m;
        self.live_per_segment = live_per_segment;
        for (k, v) in live_changes {
            match v {
                Some(l) => {
                    self.live.insert(k, l);
                }
                None => {
                    self.live.remove(&k);
                }
            }
        }
        // Leftovers are garbage whatever happens here; failing to delete them is not an error
        // of the commit, which is already durable.
        let _ = self.remove_leftovers();
        Ok(())
    }

    /// Removes the live shapes whose canonical path equals one of `paths` (each taken as
    /// given and as canonicalised with [`canonical_path`]). Returns how many were removed.
    /// Commits once; does nothing on disk if none matched.
    pub fn remove<P: AsRef<Path>>(&mut self, paths: &[P]) -> Result<usize> {
        let mut keys: Vec<String> = Vec::new();
        for p in paths {
            let p = p.as_ref();
            for cand in [p.to_path_buf(), canonical_path(p)] {
                if let Some(k) = cand.to_str()
                    && self.live.contains_key(k)
                    && !keys.iter().any(|x| x == k)
                {
                    keys.push(k.to_owned());
                }
            }
        }
        if keys.is_empty() {
            return Ok(0);
        }
        let mut m = self.manifest.clone();
        let mut live_per_segment = self.live_per_segment.clone();
        let mut changes = Vec::new();
        for k in &keys {
            if let Some(l) = self.live.get(k) {
                m.tombstones.push(l.id);
                if let Some(c) = live_per_segment.get_mut(&l.segment) {
                    *c = c.saturating_sub(1);
                }
                changes.push((k.clone(), None));
            }
        }
        self.commit(m, live_per_segment, changes)?;
        Ok(keys.len())
    }

    /// Rewrites all live shapes into fresh segments of at most `shapes_per_segment` shapes
    /// (ids kept), dropping tombstones, then deletes the old segment files. Readers that
    /// opened before keep working from their snapshot or retry on the new manifest.
    pub fn compact(&mut self, shapes_per_segment: usize) -> Result<()> {
        let per = shapes_per_segment.max(1);
        let mut live: Vec<(ShapeId, ShapeRecord<D>)> = Vec::new();
        for entry in &self.manifest.segments {
            let seg = segment::read::<D>(&self.dir, &self.manifest, entry)?;
            for (c, r) in seg.head.catalogue.into_iter().zip(seg.records) {
                if !self.manifest.is_tombstoned(c.id) {
                    live.push((c.id, r));
                }
            }
        }
        live.sort_by_key(|(id, _)| *id);
        let mut m = self.manifest.clone();
        m.segments.clear();
        m.tombstones.clear();
        let mut live_per_segment = HashMap::new();
        let mut changes = Vec::new();
        for chunk in live.chunks(per) {
            let number = m.next_segment;
            m.next_segment += 1;
            let ids: Vec<ShapeId> = chunk.iter().map(|(id, _)| *id).collect();
            let recs: Vec<ShapeRecord<D>> = chunk.iter().map(|(_, r)| r.clone()).collect();
            let (bytes, checksum) = segment::encode(number, &ids, &recs)?;
            file::write_atomic(&self.dir, &segment_file_name(number), &bytes)?;
            m.segments.push(SegmentEntry {
                number,
                len: bytes.len() as u64,
                checksum,
                shapes: recs.len() as u64,
                components: recs.iter().map(|r| r.components.len() as u64).sum(),
            });
            live_per_segment.insert(number, recs.len() as u64);
            for (id, r) in chunk {
                changes.push((
                    r.canonical_path.to_string_lossy().into_owned(),
                    Some(Live {
                        id: *id,
                        hash: r.content_hash,
                        segment: number,
                    }),
                ));
            }
        }
        self.commit(m, live_per_segment, changes)
    }

    /// Deletes files in the index directory that the current manifest does not reference:
    /// temp files (`*.tmp-*`) and unlisted segment files. Other files are left alone.
    /// Returns the paths deleted.
    pub fn remove_leftovers(&self) -> Result<Vec<PathBuf>> {
        let listed: std::collections::HashSet<u64> =
            self.manifest.segments.iter().map(|s| s.number).collect();
        let mut removed = Vec::new();
        for path in leftover_files(&self.dir, &listed)? {
            match fs::remove_file(&path) {
                Ok(()) => removed.push(path),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(IndexError::io("could not delete", path, e)),
            }
        }
        if !removed.is_empty() {
            file::sync_dir(&self.dir)?;
        }
        Ok(removed)
    }
}

/// Where two profiles differ: the JSON fields whose values differ (by dotted path, nested
/// objects followed down) when both are JSON objects, else both texts.
fn profile_difference(a: &str, b: &str) -> String {
    use serde_json::Value;
    fn walk(prefix: &str, x: &Value, y: &Value, out: &mut Vec<String>) {
        match (x, y) {
            (Value::Object(x), Value::Object(y)) => {
                let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
                keys.sort();
                keys.dedup();
                for k in keys {
                    let path = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    match (x.get(k), y.get(k)) {
                        (Some(u), Some(v)) => walk(&path, u, v, out),
                        (u, v) => {
                            let show =
                                |w: Option<&Value>| w.map_or("absent".into(), Value::to_string);
                            out.push(format!("{path}: {} vs {}", show(u), show(v)));
                        }
                    }
                }
            }
            _ if x != y => out.push(format!("{prefix}: {x} vs {y}")),
            _ => {}
        }
    }
    if let (Ok(x @ Value::Object(_)), Ok(y @ Value::Object(_))) = (
        serde_json::from_str::<Value>(a),
        serde_json::from_str::<Value>(b),
    ) {
        let mut diff = Vec::new();
        walk("", &x, &y, &mut diff);
        if !diff.is_empty() {
            return diff.join("; ");
        }
    }
    let show = |p: &str| {
        if p.is_empty() {
            "none (format 1)".to_string()
        } else {
            format!("'{p}'")
        }
    };
    format!("{} vs {}", show(a), show(b))
}
