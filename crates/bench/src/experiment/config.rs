//! What a run evaluates: the presets (key-components or the MSER methods), the keypoint
//! budget, the detection parameters, the transformations and strengths, the cache.

use std::path::{Path, PathBuf};

use keycomp_components::{ClusterParams, GeodesicOptions, Grouping, SmacofParams, SphereRule};
use keycomp_harris::{HarrisParams, Selection};
use keycomp_mesh::Mesh;
use keycomp_mser::{Method, MserParams};
use keycomp_surface::SurfaceParams;
use serde::Serialize;

use crate::cache::EmbeddingCache;
use crate::transform::Kind;

/// How many keypoints each shape gets (see *Keypoint budget* in the [module docs](super)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Budget {
    /// Every shape uses this selection on its own vertices (the paper: `Fraction(0.01)`).
    PerShape(Selection),
    /// Every shape of a null shape's set gets `round(fraction × the null shape's referenced
    /// vertices)` keypoints: a fixed count per unit of normalised area.
    NullCalibrated(f64),
}

impl Budget {
    /// One-line description for reports.
    pub fn describe(&self) -> String {
        match *self {
            Budget::PerShape(Selection::Fraction(f)) => {
                let rule = if f == 0.01 {
                    "the paper's rule"
                } else {
                    "the paper's rule takes 1 %"
                };
                format!("{} % of each shape's own vertices ({rule})", f * 100.0)
            }
            Budget::PerShape(Selection::Count(n)) => {
                format!("{n} keypoints on every shape (fixed count per unit normalised area)")
            }
            Budget::PerShape(Selection::PerArea(d)) => {
                format!("{d} keypoints per unit area on every shape (its own area counting as 1)")
            }
            Budget::PerShape(s) => format!("{s:?} on every shape"),
            Budget::NullCalibrated(f) => format!(
                "{} % of the null shape's vertices on the null and each of its transformed \
                 shapes (tessellation-independent)",
                f * 100.0
            ),
        }
    }
}

/// `round(f × n)`, at least 1: Harris' own rule for [`Selection::Fraction`].
pub(super) fn fraction_count(f: f64, referenced: usize) -> usize {
    ((f * referenced as f64).round() as usize).max(1)
}

/// Vertices that some face refers to.
pub(super) fn referenced(mesh: &Mesh) -> usize {
    let mut used = vec![false; mesh.num_vertices()];
    for f in &mesh.faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    used.iter().filter(|u| **u).count()
}

/// A named set of clustering parameters (one of the paper's presets, possibly modified).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PresetSpec {
    /// Name shown in tables (`KC-1`, …, `MSER`, `MSER-KC`); the paper's table of that name is
    /// printed beside ours. A trailing `*` marks a preset modified by options (the paper's table
    /// of the unmodified preset is still shown).
    pub name: String,
    /// The detection method; `cluster` and `sigma` are used by [`Method::Kc`] only.
    pub method: Method,
    /// R, T, N, Iter.
    pub cluster: ClusterParams,
    /// Region-growing factor σ.
    pub sigma: f64,
    /// The sphere that σ scales (the paper's enclosing sphere, or the robust preset's spread
    /// sphere).
    pub sphere: SphereRule,
    /// How keypoints become components: the paper's clustering, or the robust preset's salient
    /// regions (then `cluster`, `sigma` and `sphere` are unused, and the shape is detected in
    /// one go instead of in two cached stages).
    pub grouping: Grouping,
    /// The paper's table read beside ours (`KC-1`, …, `MSER-KC`): the preset's own for the
    /// paper's presets, KC-1's for the robust preset, none if unknown.
    pub paper_name: String,
}

impl PresetSpec {
    /// The preset of an MSER method, named as the paper's table (`MSER`, `MSER-KC`); `None`
    /// for [`Method::Kc`], whose presets are KC-1..3.
    pub fn mser(method: Method) -> Option<PresetSpec> {
        let name = match method {
            Method::Kc => return None,
            Method::Mser => "MSER",
            Method::MserKc => "MSER-KC",
        };
        Some(PresetSpec {
            name: name.to_owned(),
            method,
            cluster: ClusterParams::default(),
            sigma: 0.0,
            sphere: SphereRule::Enclosing,
            grouping: Grouping::Adaptive,
            paper_name: name.to_owned(),
        })
    }
}

/// What to run.
#[derive(Debug, Clone)]
pub struct Config {
    /// Presets to evaluate (stage 2 runs once per preset).
    pub presets: Vec<PresetSpec>,
    /// Harris parameters; `selection` is replaced according to `budget`.
    pub harris: HarrisParams,
    /// Keypoint budget.
    pub budget: Budget,
    /// SMACOF parameters (shared by all presets).
    pub smacof: SmacofParams,
    /// Parameters of the MSER methods (shared by `MSER` and `MSER-KC`; part of their cache
    /// key).
    pub mser: MserParams,
    /// Geodesic options of detection (full mesh or proxy; part of the cache key).
    pub geodesic: GeodesicOptions,
    /// Generated transformations to run.
    pub kinds: Vec<Kind>,
    /// Whether to run the real-pose isometry transformations.
    pub isometry: bool,
    /// Strengths to run (each in 1..=5).
    pub strengths: Vec<u8>,
    /// Seed of the generated transformations.
    pub seed: u64,
    /// Cache of stage-1 results (`None`: no cache).
    pub cache: Option<EmbeddingCache>,
    /// Run shapes in parallel (each detection parallelises internally as well).
    pub parallel_shapes: bool,
    /// Detect on each shape's canonical surface ([`keycomp_surface::canonical`]) instead of
    /// the mesh as generated, the components carried back to the mesh's vertices
    /// ([`Pullback::nearest`](crate::evaluate::Pullback::nearest)); `None`: on the mesh itself. Key-components only.
    pub surface: Option<SurfaceParams>,
    /// The folder of independent re-tessellations written by `scripts/retessellate.py`
    /// (`s<density>/<data subfolder>/<name>.off`), read by the rows below.
    pub remeshed: Option<PathBuf>,
    /// Run the re-tessellation row: each null shape remeshed at densities 1–5 (the
    /// strengths), its vertices mapped to the nearest null vertex.
    pub retessellation: bool,
    /// Run the remeshed-isometry row: each real pose remeshed at the middle density, its
    /// vertices mapped to the nearest vertex of the pose (numbered as the null shape's).
    pub remeshed_isometry: bool,
}

impl Config {
    /// The re-tessellation of `original` (a null shape's or a pose's file) at `density` in
    /// [`Config::remeshed`]: `s<density>/<folder of original>/<stem>.off`.
    pub(super) fn remeshed_file(&self, original: &Path, density: u8) -> Option<PathBuf> {
        let dir = self.remeshed.as_ref()?;
        let folder = original.parent()?.file_name()?;
        let stem = original.file_stem()?.to_string_lossy().into_owned();
        Some(
            dir.join(format!("s{density}"))
                .join(folder)
                .join(format!("{stem}.off")),
        )
    }

    /// The keypoint selection of `shape` under the budget (a count, resolved from the
    /// shape's or the null shape's referenced vertices).
    pub(super) fn selection_for(&self, shape: &Mesh, null_referenced: usize) -> Selection {
        match self.budget {
            Budget::PerShape(Selection::Fraction(f)) => {
                Selection::Count(fraction_count(f, referenced(shape)))
            }
            Budget::PerShape(s) => s,
            Budget::NullCalibrated(f) => Selection::Count(fraction_count(f, null_referenced)),
        }
    }
}
