//! One shape of the run: make it (the null shape, a generated transformation or a real pose),
//! detect on it (stage 1 from the cache when present, stage 2 per preset, or the MSER
//! methods), and carry its components to the null shape's vertices.

use std::borrow::Cow;
use std::path::PathBuf;
use std::time::Instant;

use keycomp_components::{ComponentParams, DetectParams, Grouping, detect};
use keycomp_harris::HarrisParams;
use keycomp_mesh::geometry::vertex_areas;
use keycomp_mesh::{Mesh, Topology, VertexId, read_mesh};
use keycomp_mser::{Method, covering_set, detect as detect_mser};
use keycomp_surface::{Input, canonical};
use serde::Serialize;

use super::config::{Config, PresetSpec};
use super::discover::{ISOMETRY, NullSpec};
use crate::cache::{Lookup, MserEntry, cache_key, mser_cache_key};
use crate::evaluate::Pullback;
use crate::staged::{Embedded, Extractor, Found, embed};
use crate::transform::{Kind, transform};

/// Where a shape came from.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Source {
    Null,
    Generated(Kind, u8),
    Pose(u8, PathBuf),
    /// An independent re-tessellation (`Config::remeshed`): of the null shape at density
    /// `strength` ([`RETESSELLATION`]), or of the pose of that strength at density
    /// [`REMESHED_POSE_DENSITY`] ([`ISOMETRY_REMESHED`]; the pose's file is given).
    Remeshed {
        strength: u8,
        pose: Option<PathBuf>,
    },
}

/// The row of the null shapes re-tessellated at densities 1–5.
pub const RETESSELLATION: &str = "retessellation";
/// The row of the real poses, each re-tessellated.
pub const ISOMETRY_REMESHED: &str = "isometry-remeshed";
/// The density (strength of [`RETESSELLATION`]) the poses of [`ISOMETRY_REMESHED`] are
/// re-tessellated at: the middle one, about 9,500 vertices per shape.
pub const REMESHED_POSE_DENSITY: u8 = 3;

pub(super) struct Job {
    pub(super) null: usize,
    pub(super) source: Source,
}

impl Job {
    pub(super) fn kind(&self) -> &str {
        match &self.source {
            Source::Null => "null",
            Source::Generated(k, _) => k.name(),
            Source::Pose(..) => ISOMETRY,
            Source::Remeshed { pose: None, .. } => RETESSELLATION,
            Source::Remeshed { pose: Some(_), .. } => ISOMETRY_REMESHED,
        }
    }
    pub(super) fn strength(&self) -> u8 {
        match &self.source {
            Source::Null => 0,
            Source::Generated(_, s) | Source::Pose(s, _) | Source::Remeshed { strength: s, .. } => {
                *s
            }
        }
    }
}

pub(super) struct LoadedNull {
    pub(super) spec: NullSpec,
    pub(super) mesh: Mesh,
    pub(super) topo: Topology,
    pub(super) areas: Vec<f64>,
    pub(super) referenced: usize,
}

/// How a shape's stage-1 result was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CacheUse {
    /// Read from the cache.
    Hit,
    /// Computed (and stored).
    Miss,
    /// Computed because the cached entry was corrupt (and overwritten).
    Corrupt,
    /// Computed, no cache in use.
    Off,
}

impl CacheUse {
    /// The less favourable of two uses (a shape with two cached stages is a hit only if both
    /// were): Corrupt, then Miss, then Off, then Hit.
    fn worse(self, other: CacheUse) -> CacheUse {
        let rank = |c: CacheUse| match c {
            CacheUse::Hit => 0,
            CacheUse::Off => 1,
            CacheUse::Miss => 2,
            CacheUse::Corrupt => 3,
        };
        if rank(other) > rank(self) {
            other
        } else {
            self
        }
    }
}

pub(super) struct Outcome {
    pub(super) vertices: usize,
    pub(super) faces: usize,
    pub(super) keypoints: usize,
    pub(super) cache: CacheUse,
    pub(super) cache_error: Option<String>,
    pub(super) seconds: f64,
    /// Per preset: the components as null-vertex sets (carried, for transformed shapes).
    pub(super) components: Vec<Vec<Vec<VertexId>>>,
    /// Per preset: each component's cluster, its keypoints carried to null vertices.
    pub(super) clusters: Vec<Vec<Vec<VertexId>>>,
    /// The keypoints carried to null vertices (a keypoint whose vertex has no image is left
    /// out).
    pub(super) keypoints_on_null: Vec<VertexId>,
}

impl Config {
    fn stage1(
        &self,
        mesh: &Mesh,
        null: &LoadedNull,
    ) -> Result<(Embedded, CacheUse, Option<String>), String> {
        let harris = HarrisParams {
            selection: self.selection_for(mesh, null.referenced),
            ..self.harris
        };
        let compute = || {
            embed(mesh, &harris, &self.smacof, &self.geodesic)
                .map_err(|e| format!("detection failed: {e}"))
        };
        let cached = self.cache.as_ref().and_then(|c| {
            cache_key(mesh, &harris, &self.smacof, &self.geodesic).map(|key| (c, key))
        });
        let Some((cache, key)) = cached else {
            return Ok((compute()?, CacheUse::Off, None));
        };
        let state = match cache.load(key, mesh.num_vertices()) {
            Lookup::Hit(e) => return Ok((e, CacheUse::Hit, None)),
            Lookup::Miss => CacheUse::Miss,
            Lookup::Corrupt => CacheUse::Corrupt,
        };
        let e = compute()?;
        let err = cache.store(key, &e).err().map(|e| e.to_string());
        Ok((e, state, err))
    }

    /// The MSER detection of `mesh` (HKS keypoints and maximally stable components), from the
    /// cache when present.
    fn mser_stage(&self, mesh: &Mesh) -> Result<(MserEntry, CacheUse, Option<String>), String> {
        let compute = || {
            detect_mser(mesh, &self.mser)
                .map(|d| MserEntry {
                    keypoints: d.keypoints,
                    components: d.components,
                })
                .map_err(|e| format!("MSER detection failed: {e}"))
        };
        let cached = self
            .cache
            .as_ref()
            .and_then(|c| mser_cache_key(mesh, &self.mser).map(|key| (c, key)));
        let Some((cache, key)) = cached else {
            return Ok((compute()?, CacheUse::Off, None));
        };
        let state = match cache.load_mser(key, mesh.num_vertices()) {
            Lookup::Hit(e) => return Ok((e, CacheUse::Hit, None)),
            Lookup::Miss => CacheUse::Miss,
            Lookup::Corrupt => CacheUse::Corrupt,
        };
        let e = compute()?;
        let err = cache.store_mser(key, &e).err().map(|e| e.to_string());
        Ok((e, state, err))
    }

    pub(super) fn run_job(&self, job: &Job, nulls: &[LoadedNull]) -> Result<Outcome, String> {
        let t0 = Instant::now();
        let null = &nulls[job.null];
        let (mesh, map): (Cow<'_, Mesh>, Option<Vec<Option<VertexId>>>) = match &job.source {
            Source::Null => (Cow::Borrowed(&null.mesh), None),
            Source::Generated(kind, s) => {
                let t = transform(&null.mesh, *kind, *s, self.seed).map_err(|e| e.to_string())?;
                (Cow::Owned(t.mesh), Some(t.map))
            }
            Source::Pose(_, path) => {
                let m = read_mesh(path).map_err(|e| e.to_string())?.mesh;
                if m.num_vertices() != null.mesh.num_vertices() {
                    return Err(format!(
                        "{}: {} vertices but the null shape has {}: not the same vertex \
                         numbering, so no ground truth",
                        path.display(),
                        m.num_vertices(),
                        null.mesh.num_vertices()
                    ));
                }
                let identity = (0..m.num_vertices() as VertexId).map(Some).collect();
                (Cow::Owned(m), Some(identity))
            }
            Source::Remeshed { strength, pose } => {
                let (original, density) = match pose {
                    None => (null.spec.path.as_path(), *strength),
                    Some(p) => (p.as_path(), REMESHED_POSE_DENSITY),
                };
                let file = self.remeshed_file(original, density).ok_or_else(|| {
                    "no --remeshed folder given (scripts/retessellate.py makes one)".to_string()
                })?;
                let m = read_mesh(&file)
                    .map_err(|e| format!("{e} (scripts/retessellate.py makes the copies)"))?
                    .mesh;
                // each remeshed vertex stands for the nearest vertex of the mesh it was made
                // from, which (a pose's vertices numbered as the null's) is a null vertex
                let reference = match pose {
                    None => Cow::Borrowed(&null.mesh),
                    Some(p) => Cow::Owned(read_mesh(p).map_err(|e| e.to_string())?.mesh),
                };
                if reference.num_vertices() != null.mesh.num_vertices() {
                    return Err(format!(
                        "{}: not the null shape's vertex numbering, so no ground truth",
                        original.display()
                    ));
                }
                let map = keycomp_surface::nearest_vertices(&m.positions, &reference.positions)
                    .map(|near| near.into_iter().map(Some).collect());
                (Cow::Owned(m), map)
            }
        };
        let wants = |kc: bool| self.presets.iter().any(|p| (p.method == Method::Kc) == kc);
        // key-components on the canonical surface when asked, carried back to `mesh`
        let surface = match &self.surface {
            Some(params) if wants(true) => Some(
                canonical(Input::Mesh(&mesh), params)
                    .map_err(|e| format!("canonical surface: {e}"))?
                    .mesh,
            ),
            _ => None,
        };
        // canonical vertex -> the mesh's vertices nearest it (Pullback::nearest)
        let carrier = surface.as_ref().map(|s| Pullback::nearest(&mesh, s));
        let detected: &Mesh = surface.as_ref().unwrap_or(&mesh);
        let staged = self
            .presets
            .iter()
            .any(|p| p.method == Method::Kc && p.grouping == Grouping::Adaptive);
        let (embedded, mut cache, mut cache_error) = if wants(true) && staged {
            let (e, c, err) = self.stage1(detected, null)?;
            (Some(e), c, err)
        } else if wants(true) {
            // salient regions only: detected without the cache
            (None, CacheUse::Off, None)
        } else {
            (None, CacheUse::Hit, None)
        };
        let mser = if wants(false) {
            let (m, c, err) = self.mser_stage(&mesh)?;
            cache = cache.worse(c);
            cache_error = cache_error.or(err);
            Some(m)
        } else {
            None
        };
        let extractor = embedded.as_ref().map(|_| Extractor::new(detected));
        // salient regions are detected in one go: no stage worth caching
        let salient = |p: &PresetSpec| -> Result<(Vec<Found>, Vec<VertexId>), String> {
            let params = DetectParams {
                harris: HarrisParams {
                    selection: self.selection_for(detected, null.referenced),
                    ..self.harris
                },
                components: ComponentParams {
                    grouping: p.grouping,
                    ..ComponentParams::default()
                },
                geodesic: self.geodesic,
            };
            let det = detect(detected, &params)
                .map_err(|e| format!("{}: detection failed: {e}", p.name))?;
            let found = det
                .components
                .into_iter()
                .map(|c| Found {
                    keypoints: c.keypoints,
                    vertices: c.vertices,
                })
                .collect();
            Ok((found, det.keypoints))
        };
        let mut salient_keypoints = None;
        let vertex_area = mser.as_ref().map(|_| vertex_areas(&mesh));
        // a detected vertex -> the nearest vertex of `mesh` (the identity without a surface)
        let to_mesh = |ids: &[VertexId]| -> Vec<VertexId> {
            match &surface {
                Some(s) => {
                    let points: Vec<_> = ids
                        .iter()
                        .filter_map(|&v| s.positions.get(v as usize).copied())
                        .collect();
                    keycomp_surface::nearest_vertices(&points, &mesh.positions).unwrap_or_default()
                }
                None => ids.to_vec(),
            }
        };
        let to_null = |ids: Vec<VertexId>| -> Vec<VertexId> {
            match &map {
                Some(map) => ids
                    .into_iter()
                    .filter_map(|v| map.get(v as usize).copied().flatten())
                    .collect(),
                None => ids,
            }
        };
        let mut components = Vec::with_capacity(self.presets.len());
        let mut clusters = Vec::with_capacity(self.presets.len());
        for p in &self.presets {
            let (comps, keys) = match (p.method, &embedded, &extractor, &mser, &vertex_area) {
                (Method::Kc, embedded, extractor, _, _)
                    if p.grouping != Grouping::Adaptive || embedded.is_some() =>
                {
                    let found = match (p.grouping, embedded, extractor) {
                        (Grouping::Adaptive, Some(e), Some(x)) => x
                            .components(e, &p.cluster, p.sigma, p.sphere)
                            .map_err(|e| format!("{}: component extraction failed: {e}", p.name))?,
                        _ => {
                            let (found, keys) = salient(p)?;
                            salient_keypoints.get_or_insert(keys);
                            found
                        }
                    };
                    let keys = found
                        .iter()
                        .map(|c| to_null(to_mesh(&c.keypoints)))
                        .collect();
                    let comps = match &carrier {
                        Some(carrier) => found.iter().map(|c| carrier.carry(&c.vertices)).collect(),
                        None => found.into_iter().map(|c| c.vertices).collect(),
                    };
                    (comps, keys)
                }
                (Method::Mser, _, _, Some(m), _) => (m.components.clone(), Vec::new()),
                (Method::MserKc, _, _, Some(m), Some(va)) => {
                    let areas: Vec<f64> = m
                        .components
                        .iter()
                        .map(|c| c.iter().map(|&v| va[v as usize]).sum())
                        .collect();
                    let (chosen, _) = covering_set(&m.components, &areas, &m.keypoints)
                        .map_err(|e| format!("{}: {e}", p.name))?;
                    let comps = chosen.iter().map(|&i| m.components[i].clone()).collect();
                    (comps, Vec::new())
                }
                _ => return Err(format!("{}: internal error: stage missing", p.name)),
            };
            components.push(comps);
            clusters.push(keys);
        }
        let (keypoints, keypoints_on_null) = match (&embedded, &mser) {
            (Some(e), _) => (e.keypoints.len(), to_null(to_mesh(&e.keypoints))),
            (None, _) if salient_keypoints.is_some() => {
                let k = salient_keypoints.unwrap_or_default();
                (k.len(), to_null(to_mesh(&k)))
            }
            (None, Some(m)) => (m.keypoints.len(), to_null(m.keypoints.clone())),
            (None, None) => (0, Vec::new()),
        };
        if let Some(map) = map {
            let pullback =
                Pullback::new(&null.mesh, &null.topo, &map).map_err(|e| e.to_string())?;
            for per_preset in &mut components {
                for c in per_preset.iter_mut() {
                    *c = pullback.carry(c);
                }
            }
        }
        Ok(Outcome {
            vertices: mesh.num_vertices(),
            faces: mesh.num_faces(),
            keypoints,
            cache,
            cache_error,
            seconds: t0.elapsed().as_secs_f64(),
            components,
            clusters,
            keypoints_on_null,
        })
    }
}
