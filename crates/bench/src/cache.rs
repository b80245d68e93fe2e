//! On-disk cache of [`Embedded`] detections (keypoints + SMACOF points), keyed by content.
//!
//! The detection caches of the benchmarks: stage-1 detections here ([`EmbeddingCache`]), MSER
//! detections beside them, and the analysed records of `keycomp bench retrieval` (in the
//! command line's crate) all live in a [`CacheFolder`], with one key rule and one invalidation
//! rule.
//!
//! **Key.** A 128-bit XXH3 hash of: a domain tag, [`CACHE_VERSION`], the running program's
//! identity ([`program_hash`], the XXH3-128 of the executable's bytes), then the entry's own
//! content (here the mesh's vertex count, every coordinate's bits, the face count and every face,
//! and the JSON of the Harris, SMACOF and geodesic parameters: full mesh or proxy, split angle).
//! Two lookups with the same key ran the same program on the same positions, faces and
//! parameters, so a cached result is theirs. Any rebuild of the program that changes its bytes
//! invalidates every entry (old entries are never looked up again; delete the folder to reclaim
//! the space), so a change of the detection code cannot be served stale results. When the
//! executable cannot be read, nothing is cached.
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
//! Writes are atomic ([`keycomp_mesh::io::output::write_file`]: a temporary file in the same
//! folder, synced, renamed over the entry), so readers see a whole entry or none. Reading checks both magics, both versions, the checksum, the key, the
//! length, that every keypoint is a vertex of the mesh and that every point is finite; an entry
//! failing any check is reported as [`Lookup::Corrupt`] and the caller recomputes and overwrites
//! it.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use keycomp_components::{GeodesicOptions, SmacofParams};
use keycomp_harris::HarrisParams;
use keycomp_mesh::{Mesh, VertexId};
use keycomp_mser::MserParams;
use xxhash_rust::xxh3::{Xxh3, xxh3_64};

use crate::error::BenchError;
use crate::staged::Embedded;

/// Version of the cache file layout.
pub const CACHE_VERSION: u32 = 1;

/// The identity of the running program: the XXH3-128 hash of its executable's bytes, read
/// once; `None` when the executable cannot be read (then nothing is cached).
pub fn program_hash() -> Option<u128> {
    static HASH: OnceLock<Option<u128>> = OnceLock::new();
    *HASH.get_or_init(|| {
        let exe = std::env::current_exe().ok()?;
        fs::read(exe).ok().map(|b| xxhash_rust::xxh3::xxh3_128(&b))
    })
}

/// A hasher for a cache key: the domain `tag`, [`CACHE_VERSION`] and the [`program_hash`] fed
/// first; `None` when the program's identity is unknown (nothing is then cached).
pub fn key_hasher(tag: &[u8]) -> Option<Xxh3> {
    let program = program_hash()?;
    let mut h = Xxh3::new();
    h.update(tag);
    h.update(b"\0");
    h.update(&CACHE_VERSION.to_le_bytes());
    h.update(&program.to_le_bytes());
    Some(h)
}

/// A folder of cache entries, one file per key (`<key as 32 hex digits>.<extension>`), created
/// on the first write. Entries are written atomically and read whole; an entry that cannot be
/// read is a miss for the caller to recompute and overwrite.
#[derive(Debug, Clone)]
pub struct CacheFolder {
    dir: PathBuf,
}

impl CacheFolder {
    /// The cache in `dir`.
    pub fn new(dir: impl Into<PathBuf>) -> CacheFolder {
        CacheFolder { dir: dir.into() }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The file of the entry `key` with `extension`.
    pub fn path(&self, key: u128, extension: &str) -> PathBuf {
        self.dir.join(format!("{key:032x}.{extension}"))
    }

    /// The entry as `decode` reads its bytes: [`Lookup::Miss`] without one,
    /// [`Lookup::Corrupt`] when it cannot be read or `decode` refuses it (`None`).
    pub fn read<T>(
        &self,
        key: u128,
        extension: &str,
        decode: impl FnOnce(&[u8]) -> Option<T>,
    ) -> Lookup<T> {
        match fs::read(self.path(key, extension)) {
            Ok(bytes) => decode(&bytes).map_or(Lookup::Corrupt, Lookup::Hit),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Lookup::Miss,
            Err(_) => Lookup::Corrupt,
        }
    }

    /// Writes the entry atomically ([`keycomp_mesh::io::output::write_file`]), creating the
    /// folder if needed.
    ///
    /// Errors: [`BenchError::Io`] with the folder or file.
    pub fn write(&self, key: u128, extension: &str, bytes: &[u8]) -> Result<(), BenchError> {
        fs::create_dir_all(&self.dir).map_err(|source| BenchError::Io {
            path: self.dir.clone(),
            source,
        })?;
        let path = self.path(key, extension);
        keycomp_mesh::io::output::write_file(&path, |w| w.write_all(bytes))
            .map_err(|source| BenchError::Io { path, source })
    }
}

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
/// [module docs](self)); `None` when the program's identity is unknown.
pub fn cache_key(
    mesh: &Mesh,
    harris: &HarrisParams,
    smacof: &SmacofParams,
    geodesic: &GeodesicOptions,
) -> Option<u128> {
    let mut h = key_hasher(b"keycomp-embedding")?;
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
    Some(h.digest128())
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
    folder: CacheFolder,
}

impl EmbeddingCache {
    /// A cache in `dir` (created on the first [`store`](Self::store)).
    pub fn new(dir: impl Into<PathBuf>) -> EmbeddingCache {
        EmbeddingCache {
            folder: CacheFolder::new(dir),
        }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        self.folder.dir()
    }

    /// Looks `key` up for a mesh of `num_vertices` vertices. Never fails: unreadable or invalid
    /// entries are [`Lookup::Corrupt`].
    pub fn load(&self, key: u128, num_vertices: usize) -> Lookup {
        self.folder
            .read(key, "emb", |bytes| decode(bytes, key, num_vertices))
    }

    /// Stores `embedded` under `key`, atomically (see the [module docs](self)).
    ///
    /// Errors: [`BenchError::Io`] with the folder or file.
    pub fn store(&self, key: u128, embedded: &Embedded) -> Result<(), BenchError> {
        self.folder.write(key, "emb", &encode(key, embedded))
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

const MSER_MAGIC: &[u8; 8] = b"KCMSER\0\0";

/// The content key of an MSER detection of `mesh` with `params`: like [`cache_key`] (domain
/// tag, version, program, every coordinate and face) with the MSER parameters' JSON; `None` when
/// the program's identity is unknown. MSER and MSER key-components share one entry (both are
/// read off the same detection).
pub fn mser_cache_key(mesh: &Mesh, params: &MserParams) -> Option<u128> {
    let mut h = key_hasher(b"keycomp-mser")?;
    hash_mesh(&mut h, mesh);
    h.update(serde_json::to_string(params).unwrap_or_default().as_bytes());
    Some(h.digest128())
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
    /// Looks an MSER detection up for a mesh of `num_vertices` vertices; file
    /// `<dir>/<key>.msr`: `magic "KCMSER\0\0" | version u32 | key u128 | K u32 | K × u32 |
    /// C u32 | C × (len u32 | len × u32)` and the footer of the embedding files. Never fails:
    /// unreadable or invalid entries (ids out of range, unsorted components) are
    /// [`Lookup::Corrupt`].
    pub fn load_mser(&self, key: u128, num_vertices: usize) -> Lookup<MserEntry> {
        self.folder
            .read(key, "msr", |bytes| decode_mser(bytes, key, num_vertices))
    }

    /// Stores an MSER detection under `key`, atomically.
    ///
    /// Errors: [`BenchError::Io`] with the folder or file.
    pub fn store_mser(&self, key: u128, entry: &MserEntry) -> Result<(), BenchError> {
        self.folder.write(key, "msr", &encode_mser(key, entry))
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
        let key = cache_key(&mesh, &h, &s, &g).expect("the test binary is readable");
        assert_eq!(cache.load(key, mesh.num_vertices()), Lookup::Miss);
        cache.store(key, &sample()).unwrap();
        assert_eq!(cache.load(key, mesh.num_vertices()), Lookup::Hit(sample()));
        // only the entry is left in the folder (no temporary file)
        assert_eq!(fs::read_dir(cache.dir()).unwrap().count(), 1);
        // every input changes the key
        let mut moved = mesh.clone();
        moved.positions[0].x += 1e-12;
        assert_ne!(Some(key), cache_key(&moved, &h, &s, &g));
        let mut flipped = mesh.clone();
        flipped.faces[0].swap(0, 1);
        assert_ne!(Some(key), cache_key(&flipped, &h, &s, &g));
        let h2 = HarrisParams {
            selection: Selection::Count(7),
            ..h
        };
        assert_ne!(Some(key), cache_key(&mesh, &h2, &s, &g));
        let s2 = SmacofParams { seed: 1, ..s };
        assert_ne!(Some(key), cache_key(&mesh, &h, &s2, &g));
        let proxy = GeodesicOptions {
            proxy_vertices: g.proxy_vertices + 1000,
            ..g
        };
        assert_ne!(Some(key), cache_key(&mesh, &h, &s, &proxy));
        let full = GeodesicOptions::full_mesh();
        assert_ne!(
            cache_key(&mesh, &h, &s, &full),
            cache_key(&mesh, &h, &s, &proxy)
        );
        let angle = GeodesicOptions {
            min_split_angle_degrees: 120.0,
            ..g
        };
        assert_ne!(Some(key), cache_key(&mesh, &h, &s, &angle));
        assert_eq!(cache_key(&mesh.clone(), &h, &s, &g), Some(key));
    }

    #[test]
    fn corrupt_entries_are_detected_not_trusted() {
        let dir = tempfile::tempdir().unwrap();
        let cache = EmbeddingCache::new(dir.path());
        let key = 0xABCD_u128;
        cache.store(key, &sample()).unwrap();
        let path = cache.folder.path(key, "emb");
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
        fs::write(cache.folder.path(7, "emb"), &good).unwrap();
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
        let key = mser_cache_key(&mesh, &p).expect("the test binary is readable");
        assert_ne!(
            Some(key),
            cache_key(
                &mesh,
                &HarrisParams::default(),
                &SmacofParams::default(),
                &GeodesicOptions::default()
            )
        );
        let other = MserParams { time: 0.05, ..p };
        assert_ne!(mser_cache_key(&mesh, &other), Some(key));
        let entry = MserEntry {
            keypoints: vec![7, 2],
            components: vec![vec![1, 2, 7], vec![], vec![3]],
        };
        assert_eq!(cache.load_mser(key, 10), Lookup::Miss);
        cache.store_mser(key, &entry).unwrap();
        assert_eq!(cache.load_mser(key, 10), Lookup::Hit(entry.clone()));
        // a vertex out of range, a flipped bit, a truncation
        assert_eq!(cache.load_mser(key, 7), Lookup::Corrupt);
        let path = cache.folder.path(key, "msr");
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
