//! On-disk cache of [`Embedded`] detections (keypoints + SMACOF points), keyed by content.
//!
//! **Key.** A 128-bit XXH3 hash of: a domain tag, [`CACHE_VERSION`], [`DETECTION_VERSION`],
//! the mesh's vertex count, every coordinate's bits, the face count and every face, and the
//! JSON of the Harris, SMACOF and geodesic parameters (full mesh or proxy, split angle). Two shapes with the same key have the same
//! positions, faces and parameters, so the cached stage-1 result is theirs. A change of the
//! detection code that changes results must bump [`DETECTION_VERSION`] (old entries are then
//! never looked up again; delete the folder to reclaim the space).
//!
//! **File** `<dir>/<key as 32 hex digits>.emb`, little endian:
//!
//! ```text
//! magic "KCEMBED\0" | version u32 | key u128 | K u32 | K × keypoint u32 | K × (x f64, y f64)
//! | footer: checksum u64 (XXH3-64 of everything before it) | version u32 | magic
//! ```
//!
//! MSER detections (`keycomp_mser`, for the methods `mser` and `mser-kc`) are cached in the same
//! folder as `<key>.msr` files: [`mser_cache_key`], [`EmbeddingCache::load_mser`].
//!
//! Writes are atomic (temporary file in the same folder, `sync_data`, rename), so readers see a
//! whole entry or none. Reading checks both magics, both versions, the checksum, the key, the
//! length, that every keypoint is a vertex of the mesh and that every point is finite; an entry
//! failing any check is reported as [`Lookup::Corrupt`] and the caller recomputes and overwrites
//! it.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use keycomp_components::{GeodesicOptions, SmacofParams};
use keycomp_harris::HarrisParams;
use keycomp_mesh::{Mesh, VertexId};
use keycomp_mser::MserParams;
use xxhash_rust::xxh3::{Xxh3, xxh3_64};

use crate::BenchError;
use crate::staged::Embedded;

/// Version of the cache file layout.
pub const CACHE_VERSION: u32 = 1;

/// Version of the detection code whose results are cached: the package version and a counter
/// bumped whenever Harris, fast marching or SMACOF change their results.
pub const DETECTION_VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "+det1");

const MAGIC: &[u8; 8] = b"KCEMBED\0";
const HEADER: usize = 8 + 4 + 16 + 4;
const FOOTER: usize = 8 + 4 + 8;

/// Feeds every coordinate (exact bits) and face of `mesh`, with their counts, to `h`.
fn hash_mesh(h: &mut Xxh3, mesh: &Mesh) {
    h.update(&(mesh.positions.len() as u64).to_le_bytes());
    for p in &mesh.positions {
        for c in [p.x, p.y, p.z] {
            h.update(&c.to_bits().to_le_bytes());
        }
    }
    h.update(&(mesh.faces.len() as u64).to_le_bytes());
    for f in &mesh.faces {
        for v in f {
            h.update(&v.to_le_bytes());
        }
    }
}

/// The content key of a stage-1 detection of `mesh` with these parameters (see the
/// [module docs](self)).
pub fn cache_key(
    mesh: &Mesh,
    harris: &HarrisParams,
    smacof: &SmacofParams,
    geodesic: &GeodesicOptions,
) -> u128 {
    let mut h = Xxh3::new();
    h.update(b"keycomp-embedding\0");
    h.update(&CACHE_VERSION.to_le_bytes());
    h.update(DETECTION_VERSION.as_bytes());
    hash_mesh(&mut h, mesh);
    // serialising plain parameter structs cannot fail; an empty string would still be a key
    h.update(serde_json::to_string(harris).unwrap_or_default().as_bytes());
    h.update(b"\0");
    h.update(serde_json::to_string(smacof).unwrap_or_default().as_bytes());
    h.update(b"\0");
    h.update(
        serde_json::to_string(geodesic)
            .unwrap_or_default()
            .as_bytes(),
    );
    h.digest128()
}

/// The outcome of [`EmbeddingCache::load`] (and, with [`MserEntry`], of
/// [`EmbeddingCache::load_mser`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Lookup<T = Embedded> {
    /// A valid entry.
    Hit(T),
    /// No entry for the key.
    Miss,
    /// An entry exists but fails a check (truncated, wrong version, bad checksum, …).
    Corrupt,
}

/// A folder of cached stage-1 detections.
#[derive(Debug, Clone)]
pub struct EmbeddingCache {
    dir: PathBuf,
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

impl EmbeddingCache {
    /// A cache in `dir` (created on the first [`store`](Self::store)).
    pub fn new(dir: impl Into<PathBuf>) -> EmbeddingCache {
        EmbeddingCache { dir: dir.into() }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn path(&self, key: u128) -> PathBuf {
        self.dir.join(format!("{key:032x}.emb"))
    }

    /// Looks `key` up for a mesh of `num_vertices` vertices. Never fails: unreadable or invalid
    /// entries are [`Lookup::Corrupt`].
    pub fn load(&self, key: u128, num_vertices: usize) -> Lookup {
        match fs::read(self.path(key)) {
            Ok(bytes) => decode(&bytes, key, num_vertices).map_or(Lookup::Corrupt, Lookup::Hit),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Lookup::Miss,
            Err(_) => Lookup::Corrupt,
        }
    }

    /// Stores `embedded` under `key`, atomically (see the [module docs](self)).
    ///
    /// Errors: [`BenchError::Io`] with the folder or file.
    pub fn store(&self, key: u128, embedded: &Embedded) -> Result<(), BenchError> {
        self.write_entry(
            self.path(key),
            &format!("{key:032x}"),
            &encode(key, embedded),
        )
    }

    /// Writes `bytes` to `path` in the cache folder through a temporary file named after
    /// `stem`, fsync and rename (see the [module docs](self)).
    fn write_entry(&self, path: PathBuf, stem: &str, bytes: &[u8]) -> Result<(), BenchError> {
        fs::create_dir_all(&self.dir).map_err(|source| BenchError::Io {
            path: self.dir.clone(),
            source,
        })?;
        let tmp = self.dir.join(format!(
            ".{stem}.{}.{}.tmp",
            std::process::id(),
            TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let result = (|| -> std::io::Result<()> {
            let mut f = fs::File::create(&tmp)?;
            f.write_all(bytes)?;
            f.sync_data()?;
            fs::rename(&tmp, &path)
        })();
        if result.is_err() {
            let _ = fs::remove_file(&tmp);
        }
        result.map_err(|source| BenchError::Io { path, source })
    }
}

fn encode(key: u128, e: &Embedded) -> Vec<u8> {
    let k = e.keypoints.len();
    let mut b = Vec::with_capacity(HEADER + k * 20 + FOOTER);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&CACHE_VERSION.to_le_bytes());
    b.extend_from_slice(&key.to_le_bytes());
    b.extend_from_slice(&(k as u32).to_le_bytes());
    for v in &e.keypoints {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for p in &e.points {
        b.extend_from_slice(&p[0].to_le_bytes());
        b.extend_from_slice(&p[1].to_le_bytes());
    }
    let sum = xxh3_64(&b);
    b.extend_from_slice(&sum.to_le_bytes());
    b.extend_from_slice(&CACHE_VERSION.to_le_bytes());
    b.extend_from_slice(MAGIC);
    b
}

/// Little-endian reader over a byte slice; `None` past the end.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let (head, rest) = self.0.split_first_chunk::<N>()?;
        self.0 = rest;
        Some(*head)
    }
    fn u32(&mut self) -> Option<u32> {
        self.take().map(u32::from_le_bytes)
    }
    fn f64(&mut self) -> Option<f64> {
        self.take().map(f64::from_le_bytes)
    }
}

fn decode(bytes: &[u8], key: u128, num_vertices: usize) -> Option<Embedded> {
    let body_len = bytes.len().checked_sub(FOOTER)?;
    let (body, footer) = bytes.split_at(body_len);
    let mut f = Reader(footer);
    let sum = u64::from_le_bytes(f.take()?);
    if f.u32()? != CACHE_VERSION || &f.take::<8>()? != MAGIC || sum != xxh3_64(body) {
        return None;
    }
    let mut r = Reader(body);
    if &r.take::<8>()? != MAGIC || r.u32()? != CACHE_VERSION {
        return None;
    }
    if u128::from_le_bytes(r.take()?) != key {
        return None;
    }
    let k = r.u32()? as usize;
    if r.0.len() != k.checked_mul(20)? {
        return None;
    }
    let mut keypoints = Vec::with_capacity(k);
    for _ in 0..k {
        let v = r.u32()?;
        if v as usize >= num_vertices {
            return None;
        }
        keypoints.push(v);
    }
    let mut points = Vec::with_capacity(k);
    for _ in 0..k {
        let p = [r.f64()?, r.f64()?];
        if !(p[0].is_finite() && p[1].is_finite()) {
            return None;
        }
        points.push(p);
    }
    Some(Embedded { keypoints, points })
}

/// Version of the MSER detection code whose results are cached ([`mser_cache_key`]): bump the
/// counter whenever `keycomp_mser` or `keycomp_spectral` change their results.
pub const MSER_VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "+mser1");

const MSER_MAGIC: &[u8; 8] = b"KCMSER\0\0";

/// The content key of an MSER detection of `mesh` with `params`: like [`cache_key`] (domain
/// tag, versions, every coordinate and face) with the MSER parameters' JSON. MSER and MSER
/// key-components share one entry (both are read off the same detection).
pub fn mser_cache_key(mesh: &Mesh, params: &MserParams) -> u128 {
    let mut h = Xxh3::new();
    h.update(b"keycomp-mser\0");
    h.update(&CACHE_VERSION.to_le_bytes());
    h.update(MSER_VERSION.as_bytes());
    hash_mesh(&mut h, mesh);
    h.update(serde_json::to_string(params).unwrap_or_default().as_bytes());
    h.digest128()
}

/// A cached MSER detection: the HKS keypoints (best first) and the maximally stable
/// components (sorted vertex ids, most stable first).
#[derive(Debug, Clone, PartialEq)]
pub struct MserEntry {
    /// HKS keypoints.
    pub keypoints: Vec<VertexId>,
    /// Vertex sets of the maximally stable components.
    pub components: Vec<Vec<VertexId>>,
}

impl EmbeddingCache {
    fn mser_path(&self, key: u128) -> PathBuf {
        self.dir.join(format!("{key:032x}.msr"))
    }

    /// Looks an MSER detection up for a mesh of `num_vertices` vertices; file
    /// `<dir>/<key>.msr`: `magic "KCMSER\0\0" | version u32 | key u128 | K u32 | K × u32 |
    /// C u32 | C × (len u32 | len × u32)` and the footer of the embedding files. Never fails:
    /// unreadable or invalid entries (ids out of range, unsorted components) are
    /// [`Lookup::Corrupt`].
    pub fn load_mser(&self, key: u128, num_vertices: usize) -> Lookup<MserEntry> {
        match fs::read(self.mser_path(key)) {
            Ok(bytes) => {
                decode_mser(&bytes, key, num_vertices).map_or(Lookup::Corrupt, Lookup::Hit)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Lookup::Miss,
            Err(_) => Lookup::Corrupt,
        }
    }

    /// Stores an MSER detection under `key`, atomically.
    ///
    /// Errors: [`BenchError::Io`] with the folder or file.
    pub fn store_mser(&self, key: u128, entry: &MserEntry) -> Result<(), BenchError> {
        self.write_entry(
            self.mser_path(key),
            &format!("{key:032x}.msr"),
            &encode_mser(key, entry),
        )
    }
}

fn encode_mser(key: u128, e: &MserEntry) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(MSER_MAGIC);
    b.extend_from_slice(&CACHE_VERSION.to_le_bytes());
    b.extend_from_slice(&key.to_le_bytes());
    b.extend_from_slice(&(e.keypoints.len() as u32).to_le_bytes());
    for v in &e.keypoints {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&(e.components.len() as u32).to_le_bytes());
    for c in &e.components {
        b.extend_from_slice(&(c.len() as u32).to_le_bytes());
        for v in c {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let sum = xxh3_64(&b);
    b.extend_from_slice(&sum.to_le_bytes());
    b.extend_from_slice(&CACHE_VERSION.to_le_bytes());
    b.extend_from_slice(MSER_MAGIC);
    b
}

fn decode_mser(bytes: &[u8], key: u128, num_vertices: usize) -> Option<MserEntry> {
    let body_len = bytes.len().checked_sub(FOOTER)?;
    let (body, footer) = bytes.split_at(body_len);
    let mut f = Reader(footer);
    let sum = u64::from_le_bytes(f.take()?);
    if f.u32()? != CACHE_VERSION || &f.take::<8>()? != MSER_MAGIC || sum != xxh3_64(body) {
        return None;
    }
    let mut r = Reader(body);
    if &r.take::<8>()? != MSER_MAGIC || r.u32()? != CACHE_VERSION {
        return None;
    }
    if u128::from_le_bytes(r.take()?) != key {
        return None;
    }
    let ids = |r: &mut Reader<'_>, sorted: bool| -> Option<Vec<VertexId>> {
        let k = r.u32()? as usize;
        if r.0.len() < k.checked_mul(4)? {
            return None;
        }
        let mut out = Vec::with_capacity(k);
        for _ in 0..k {
            let v = r.u32()?;
            if v as usize >= num_vertices || (sorted && out.last().is_some_and(|&l| l >= v)) {
                return None;
            }
            out.push(v);
        }
        Some(out)
    };
    let keypoints = ids(&mut r, false)?;
    let c = r.u32()? as usize;
    let mut components = Vec::with_capacity(c.min(1 << 16));
    for _ in 0..c {
        components.push(ids(&mut r, true)?);
    }
    if !r.0.is_empty() {
        return None;
    }
    Some(MserEntry {
        keypoints,
        components,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_harris::Selection;
    use keycomp_mesh::synth;

    fn sample() -> Embedded {
        Embedded {
            keypoints: vec![3, 1, 4],
            points: vec![[0.5, -1.0], [0.0, 0.25], [1e-9, 2.0]],
        }
    }

    #[test]
    fn round_trip_miss_and_key_sensitivity() {
        let dir = tempfile::tempdir().unwrap();
        let cache = EmbeddingCache::new(dir.path().join("c"));
        let mesh = synth::icosphere(1, 1.0);
        let h = HarrisParams::default();
        let s = SmacofParams::default();
        let g = GeodesicOptions::default();
        let key = cache_key(&mesh, &h, &s, &g);
        assert_eq!(cache.load(key, mesh.num_vertices()), Lookup::Miss);
        cache.store(key, &sample()).unwrap();
        assert_eq!(cache.load(key, mesh.num_vertices()), Lookup::Hit(sample()));
        // only the entry is left in the folder (no temporary file)
        assert_eq!(fs::read_dir(cache.dir()).unwrap().count(), 1);
        // every input changes the key
        let mut moved = mesh.clone();
        moved.positions[0].x += 1e-12;
        assert_ne!(cache_key(&moved, &h, &s, &g), key);
        let mut flipped = mesh.clone();
        flipped.faces[0].swap(0, 1);
        assert_ne!(cache_key(&flipped, &h, &s, &g), key);
        let h2 = HarrisParams {
            selection: Selection::Count(7),
            ..h
        };
        assert_ne!(cache_key(&mesh, &h2, &s, &g), key);
        let s2 = SmacofParams { seed: 1, ..s };
        assert_ne!(cache_key(&mesh, &h, &s2, &g), key);
        let proxy = GeodesicOptions {
            proxy_vertices: g.proxy_vertices + 1000,
            ..g
        };
        assert_ne!(cache_key(&mesh, &h, &s, &proxy), key);
        let full = GeodesicOptions::full_mesh();
        assert_ne!(
            cache_key(&mesh, &h, &s, &full),
            cache_key(&mesh, &h, &s, &proxy)
        );
        let angle = GeodesicOptions {
            min_split_angle_degrees: 120.0,
            ..g
        };
        assert_ne!(cache_key(&mesh, &h, &s, &angle), key);
        assert_eq!(cache_key(&mesh.clone(), &h, &s, &g), key);
    }

    #[test]
    fn corrupt_entries_are_detected_not_trusted() {
        let dir = tempfile::tempdir().unwrap();
        let cache = EmbeddingCache::new(dir.path());
        let key = 0xABCD_u128;
        cache.store(key, &sample()).unwrap();
        let path = cache.path(key);
        let good = fs::read(&path).unwrap();
        let corrupt = |bytes: &[u8]| {
            fs::write(&path, bytes).unwrap();
            cache.load(key, 10)
        };
        // a flipped bit in the body fails the checksum
        let mut b = good.clone();
        b[HEADER + 1] ^= 1;
        assert_eq!(corrupt(&b), Lookup::Corrupt);
        // truncated, empty, garbage
        assert_eq!(corrupt(&good[..good.len() - 3]), Lookup::Corrupt);
        assert_eq!(corrupt(&[]), Lookup::Corrupt);
        assert_eq!(
            corrupt(b"not a cache file at all, but long enough"),
            Lookup::Corrupt
        );
        // a valid file under another key, or for a smaller mesh, is not used
        fs::write(&path, &good).unwrap();
        assert_eq!(cache.load(key, 10), Lookup::Hit(sample()));
        assert_eq!(cache.load(key, 4), Lookup::Corrupt);
        fs::write(cache.path(7), &good).unwrap();
        assert_eq!(cache.load(7, 10), Lookup::Corrupt);
        // storing again repairs the entry
        fs::write(&path, b"junk").unwrap();
        cache.store(key, &sample()).unwrap();
        assert_eq!(cache.load(key, 10), Lookup::Hit(sample()));
    }

    #[test]
    fn mser_entries_round_trip_and_reject_corruption() {
        let dir = tempfile::tempdir().unwrap();
        let cache = EmbeddingCache::new(dir.path());
        let mesh = synth::icosphere(1, 1.0);
        let p = MserParams::default();
        let key = mser_cache_key(&mesh, &p);
        assert_ne!(
            key,
            cache_key(
                &mesh,
                &HarrisParams::default(),
                &SmacofParams::default(),
                &GeodesicOptions::default()
            )
        );
        let other = MserParams { time: 0.05, ..p };
        assert_ne!(mser_cache_key(&mesh, &other), key);
        let entry = MserEntry {
            keypoints: vec![7, 2],
            components: vec![vec![1, 2, 7], vec![], vec![3]],
        };
        assert_eq!(cache.load_mser(key, 10), Lookup::Miss);
        cache.store_mser(key, &entry).unwrap();
        assert_eq!(cache.load_mser(key, 10), Lookup::Hit(entry.clone()));
        // a vertex out of range, a flipped bit, a truncation
        assert_eq!(cache.load_mser(key, 7), Lookup::Corrupt);
        let path = cache.mser_path(key);
        let good = fs::read(&path).unwrap();
        let mut b = good.clone();
        b[HEADER + 2] ^= 1;
        fs::write(&path, &b).unwrap();
        assert_eq!(cache.load_mser(key, 10), Lookup::Corrupt);
        fs::write(&path, &good[..good.len() - 1]).unwrap();
        assert_eq!(cache.load_mser(key, 10), Lookup::Corrupt);
        // an unsorted component is rejected even with a valid checksum
        let bad = MserEntry {
            keypoints: vec![],
            components: vec![vec![3, 1]],
        };
        fs::write(&path, encode_mser(key, &bad)).unwrap();
        assert_eq!(cache.load_mser(key, 10), Lookup::Corrupt);
    }

    #[test]
    fn store_into_an_impossible_folder_names_it() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("file");
        fs::write(&file, b"x").unwrap();
        let cache = EmbeddingCache::new(file.join("sub"));
        let e = cache.store(1, &sample()).unwrap_err();
        assert!(e.to_string().contains("sub"), "{e}");
    }
}
