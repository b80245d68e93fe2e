//! Indexed shapes for the web app: the index snapshot (reopened when the index commits), the
//! list of shapes, their analysed meshes (a few kept in memory), coloured GLB and thumbnails.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

use keycomp::collection::Reader;
use keycomp_geodesic::GeodesicSolver;
use keycomp_index::{ShapeId, ShapeRecord};
use keycomp_mesh::Mesh;
use keycomp_surface::SurfaceParams;
use rayon::prelude::*;
use serde::Serialize;

use super::ApiError;
use crate::colors;
use crate::report::{index_surface, load_indexed, paint_parts, picture};

/// Parts coloured in a GLB when the request lists none.
pub(crate) const DEFAULT_PARTS: usize = 16;
/// Side of a thumbnail, pixels.
pub(crate) const THUMB_SIZE: u32 = 256;
/// Analysed meshes kept in memory.
const MESHES_KEPT: usize = 8;

/// An indexed shape's record.
type Record = Arc<ShapeRecord<{ keycomp_describe::DIM }>>;
/// The mesh a shape was analysed on, and its geodesic solver.
type Analysed = Arc<(Mesh, GeodesicSolver)>;

/// One shape of the listing.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Row {
    pub(crate) id: u64,
    pub(crate) path: String,
    pub(crate) vertices: u32,
    pub(crate) faces: u32,
    pub(crate) parts: usize,
}

/// A snapshot of the index and what is derived from it.
pub(crate) struct Snapshot {
    /// When and how big the manifest was when opened: a commit replaces it.
    stamp: Option<(SystemTime, u64)>,
    pub(crate) reader: Reader,
    pub(crate) surface: Option<SurfaceParams>,
    /// The listing, built on first use.
    rows: std::sync::OnceLock<Result<Vec<Row>, String>>,
    /// Shape ids by path, built from the listing on first use.
    ids: std::sync::OnceLock<std::collections::HashMap<String, u64>>,
}

impl Snapshot {
    /// The shapes by increasing id.
    pub(crate) fn rows(&self) -> Result<&[Row], ApiError> {
        self.rows
            .get_or_init(|| {
                // one record at a time per thread: a listing must not hold every record (about
                // 50 kB each with its layout and sample) at once
                let ids: Vec<ShapeId> = self.reader.ids().collect();
                ids.par_iter()
                    .map(|&id| {
                        let r = self
                            .reader
                            .get(id)
                            .map_err(|e| e.to_string())?
                            .ok_or_else(|| format!("shape {id} vanished from its snapshot"))?;
                        Ok(Row {
                            id: id.0,
                            path: r.path.display().to_string(),
                            vertices: r.vertex_count,
                            faces: r.face_count,
                            parts: r.components.len(),
                        })
                    })
                    .collect()
            })
            .as_deref()
            .map_err(|e| ApiError::internal(e.clone()))
    }

    /// The id of the shape indexed under `path` (as a query's results name it), if any.
    pub(crate) fn id_of(&self, path: &str) -> Result<Option<u64>, ApiError> {
        let rows = self.rows()?;
        let ids = self
            .ids
            .get_or_init(|| rows.iter().map(|r| (r.path.clone(), r.id)).collect());
        Ok(ids.get(path).copied())
    }

    /// The record of shape `id`, or 404.
    pub(crate) fn record(&self, id: u64) -> Result<Record, ApiError> {
        self.reader
            .get(ShapeId(id))
            .map_err(|e| ApiError::internal(e.to_string()))?
            .ok_or_else(|| ApiError::not_found(format!("no shape {id} in the index")))
    }
}

fn manifest_stamp(dir: &Path) -> Option<(SystemTime, u64)> {
    let m = std::fs::metadata(dir.join("MANIFEST")).ok()?;
    Some((m.modified().ok()?, m.len()))
}

/// The index as last committed, reopened when its manifest changes.
pub(crate) struct Index {
    dir: PathBuf,
    current: Mutex<Arc<Snapshot>>,
    meshes: Mutex<VecDeque<(u64, [u8; 16], Analysed)>>,
}

impl Index {
    /// Opens the index at `dir`.
    pub(crate) fn open(dir: &Path) -> anyhow::Result<Index> {
        let snapshot = open_snapshot(dir).map_err(anyhow::Error::msg)?;
        Ok(Index {
            dir: dir.to_path_buf(),
            current: Mutex::new(Arc::new(snapshot)),
            meshes: Mutex::new(VecDeque::new()),
        })
    }

    /// The latest snapshot (the one in use when the index has not committed since, or when
    /// the new one cannot be opened).
    pub(crate) fn snapshot(&self) -> Arc<Snapshot> {
        let mut cur = lock(&self.current);
        if manifest_stamp(&self.dir) != cur.stamp
            && let Ok(s) = open_snapshot(&self.dir)
        {
            *cur = Arc::new(s);
        }
        cur.clone()
    }

    /// The analysed mesh of shape `id` with its solver (read, checked against its content
    /// hash, on the canonical surface when the profile has one).
    pub(crate) fn mesh(&self, snap: &Snapshot, id: u64) -> Result<(Record, Analysed), ApiError> {
        let record = snap.record(id)?;
        let hash = record.content_hash.0;
        if let Some((_, _, m)) = lock(&self.meshes)
            .iter()
            .find(|(i, h, _)| *i == id && *h == hash)
        {
            return Ok((record, m.clone()));
        }
        let loaded = load_indexed(
            &record.canonical_path,
            record.content_hash,
            snap.surface.as_ref(),
        )
        .map_err(|why| ApiError::not_found(format!("{}: {why}", record.path.display())))?;
        let loaded = Arc::new(loaded);
        let mut kept = lock(&self.meshes);
        kept.push_front((id, hash, loaded.clone()));
        kept.truncate(MESHES_KEPT);
        Ok((record, loaded))
    }

    /// GLB of shape `id` with `parts` (default: the first [`DEFAULT_PARTS`]) coloured, the
    /// k-th listed with the palette's k-th colour, larger parts under smaller ones; parts
    /// covering the whole surface are left grey (`paint_parts`).
    pub(crate) fn glb(&self, id: u64, parts: Option<Vec<usize>>) -> Result<Vec<u8>, ApiError> {
        let snap = self.snapshot();
        let (record, loaded) = self.mesh(&snap, id)?;
        let (mesh, solver) = &*loaded;
        let parts =
            parts.unwrap_or_else(|| (0..record.components.len().min(DEFAULT_PARTS)).collect());
        let paint: Vec<(usize, [u8; 3])> = parts
            .iter()
            .enumerate()
            .map(|(k, &p)| (p, colors::distinct(k)))
            .collect();
        let cols = paint_parts(mesh, solver, &record, &paint, colors::GREY);
        Ok(keycomp_mesh::glb_bytes(mesh, Some(&cols)))
    }

    /// PNG thumbnail of shape `id`: from `DIR/thumbnails/HASH.png`, else rendered and kept
    /// there (when the folder can be written).
    pub(crate) fn thumbnail(&self, id: u64) -> Result<Vec<u8>, ApiError> {
        let snap = self.snapshot();
        let record = snap.record(id)?;
        let folder = self.dir.join("thumbnails");
        let file = folder.join(format!("{}.png", record.content_hash.to_hex()));
        if let Ok(bytes) = std::fs::read(&file) {
            return Ok(bytes);
        }
        let (_, loaded) = self.mesh(&snap, id)?;
        let mesh = &loaded.0;
        let bytes = picture(mesh, &vec![colors::GREY; mesh.num_vertices()], THUMB_SIZE)
            .map_err(|e| ApiError::internal(format!("{}: {e:#}", record.path.display())))?;
        // a cache: a folder that cannot be written only costs rendering again
        let _ = std::fs::create_dir_all(&folder)
            .and_then(|_| keycomp_mesh::io::output::write_file(&file, |w| w.write_all(&bytes)));
        Ok(bytes)
    }
}

fn open_snapshot(dir: &Path) -> Result<Snapshot, String> {
    let stamp = manifest_stamp(dir);
    let reader = Reader::open_mapped(dir).map_err(|e| e.to_string())?;
    Ok(Snapshot {
        stamp,
        surface: index_surface(&reader),
        reader,
        rows: std::sync::OnceLock::new(),
        ids: std::sync::OnceLock::new(),
    })
}

/// Locks `m`, whether or not another thread panicked while holding it (plain caches).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
