//! The repeatability experiment of Sipiran & Bustos (2013), Section 4, on generated data:
//! null shapes, their transformed versions with ground-truth maps, detection on all of them,
//! overlap of carried components, and the paper's tables and curves.
//!
//! The steps, one file each:
//! 1. `discover.rs`: the null shapes and their real poses in a data folder ([`discover`]);
//! 2. `config.rs`: what a run evaluates ([`Config`], [`PresetSpec`], [`Budget`]);
//! 3. `shape.rs`: one shape made, detected and carried to its null shape;
//! 4. `run.rs`: every shape of every null shape, scored ([`run`]);
//! 5. `score.rs`: the paper's tables and curves from the best overlaps;
//! 6. `report.rs` and `markdown.rs`: the results ([`Report`], [`RunStats`]) and their
//!    markdown tables.
//!
//! **Data** ([`discover`]). A folder in the layout of `../shared/data` (it has a `tosca/` or
//! `kids/` subfolder) gives:
//! - TOSCA: per class (file-name prefix: `cat`, `centaur`, `dog`, `horse`, `wolf`, …) the null
//!   shape is pose 0 (`cat0.off`); the other poses, in increasing pose number, are its isometry
//!   transformations with strengths 1, 2, … (at most 5: `cat1`–`cat5`; `horse5, 6, 7, 10, 14`;
//!   `wolf1, 2` give strengths 1 and 2 only). Pose numbers carry no order of deformation, so
//!   the isometry strengths are just five different poses, as SHREC'10's five isometry shapes
//!   per null are.
//! - KIDS: `ID.null.0.EXT` is a null shape and `ID.isometry.K.EXT` (K = 1..5) its isometry of
//!   strength K.
//! - FAUST (with a `faust/` subfolder): subject 0's pose 0, `tr_reg_000`, is a null shape and
//!   its poses `tr_reg_001`–`tr_reg_005` its isometries of strengths 1–5.
//!
//! Poses share the null shape's vertex numbering, so their map is the identity (a pose whose
//! vertex count differs is skipped with a reason). Any other folder: every mesh file directly
//! in it (`.off`, `.obj`, `.ply`, `.stl`, by name) is a null shape, with no isometry.
//!
//! **Run** ([`run`]). Per null shape X: the selected [`Kind`](crate::transform::Kind)s ×
//! strengths are generated with [`transform`](crate::transform::transform) (seeded; a
//! transformation that cannot be applied, such as `topology` on a convex shape, is skipped
//! with its reason). Every shape — X, each transformed Y, each pose — goes through stage 1 of
//! detection once ([`embed`](crate::staged::embed): Harris, fast marching, SMACOF; read from
//! the [`EmbeddingCache`](crate::cache::EmbeddingCache) when present) and through stage 2 once
//! per preset (clustering and region growing). Each component of Y is carried to X
//! ([`Pullback`](crate::evaluate::Pullback)) and scored by its best overlap with a component
//! of X of the same preset ([`best_overlaps`](crate::evaluate::best_overlaps)). Shapes run in
//! parallel (rayon, in the caller's thread pool) when [`Config::parallel_shapes`] is set.
//!
//! **Methods** ([`Method`](keycomp_mser::Method)). Each [`PresetSpec`] names a detection
//! method: key-components (`kc`, the presets KC-1..3, stages as above) or the paper's
//! comparison method of Section 4.4 (`mser`: every diffusion-geometric maximally stable
//! component, Table 5; `mser-kc`: the MSER key-components, Table 6; [`PresetSpec::mser`]).
//! Both MSER presets read their components off one `keycomp_mser::detect` per shape with
//! [`Config::mser`] (Laplace–Beltrami spectrum of the full mesh, no simplification), cached
//! beside the stage-1 entries
//! ([`EmbeddingCache::load_mser`](crate::cache::EmbeddingCache::load_mser), keyed by content,
//! MSER parameters and [`crate::cache::CACHE_VERSION`]). The keypoint budget does not apply to
//! them (HKS keypoints are the 2-ring maxima, however many).
//!
//! **Keypoint budget** ([`Budget`]). The paper's presets take 1 % of *each shape's own* vertex
//! count (`Budget::PerShape(Selection::Fraction(0.01))`), so a shape decimated to 12 % of its
//! vertices gets 12 % of the keypoints. `Budget::NullCalibrated(0.01)` gives every shape of a
//! null shape's set the same count, 1 % of the *null shape's* vertices: since every shape is
//! normalised to unit area before detection, this is a fixed number of keypoints per unit of
//! normalised area, independent of how the surface is tessellated. A fraction is resolved to a
//! count per shape before detection (`round(f · referenced vertices)`, at least 1, exactly as
//! Harris does), so shapes whose counts agree share cache entries across budgets.
//!
//! **Output** ([`Report`]): per preset the paper's Table 1 layout (mean best overlap per
//! transformation and cumulative strength, and the mean row), repeatability at overlap 0.8, the
//! repeatability-vs-overlap curve per transformation over all selected strengths (Figs. 7–9),
//! the paper's own table, and every shape's per-component best overlaps.
//!
//! Cost: stage 1 dominates, O(K·|V| log |V|) per shape; stage 2 and the overlaps are
//! milliseconds.

mod config;
mod discover;
mod markdown;
mod report;
mod run;
mod score;
mod shape;
#[cfg(test)]
mod tests;

pub use config::{Budget, Config, PresetSpec};
pub use discover::{ISOMETRY, NullSpec, PoseSpec, discover};
pub use report::{
    CLUSTER_RADIUS, CurveReport, KEYPOINT_RADIUS, PresetReport, PresetScores, REPORT_FORMAT,
    Report, RunStats, ShapeReport, Skipped, StageRow,
};
pub use run::{Progress, run};
pub use score::{PAPER_OVERLAP, thresholds};
pub use shape::{CacheUse, ISOMETRY_REMESHED, REMESHED_POSE_DENSITY, RETESSELLATION};
