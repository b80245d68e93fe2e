//! The parameters of description ([`DescribeParams`]): the length unit, the smoothing, the
//! radii of the patch levels and how many patches each holds, and the bounds
//! ([`MAX_LEVELS`], [`MAX_PATCHES_PER_LEVEL`], [`MAX_SMOOTHING_ITERATIONS`]) on the work
//! parameters read from an index's profile may ask for. A query with a boundary is described
//! under several scale hypotheses ([`DescribeParams::for_query`]).

use keycomp_mesh::{Mesh, Topology};
use serde::{Deserialize, Serialize};

/// The length unit shapes are measured in before description.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Units {
    /// Scale-free: every mesh is scaled to unit area on its own, so a fragment is measured in
    /// units of its own size (the default).
    #[default]
    ScaleFree,
    /// Known units: every mesh is measured in file units divided by `length` (the collection's
    /// typical size, e.g. the square root of its median area), so a fragment keeps its
    /// source's scale.
    File {
        /// The length unit, in file units (> 0).
        length: f64,
    },
}

/// Parameters of [`describe_with`](crate::describe_with).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DescribeParams {
    /// Taubin λ|μ pairs applied to the surface before describing (see the crate documentation,
    /// *Smoothing*). Default 30; 0 describes the surface as it is.
    pub smoothing_iterations: usize,
    /// Smoothing as a length in the description's unit instead of a number of passes
    /// (`keycomp_harris::smoothing_passes`: `round((length / ē)⁴)` pairs for ē the mean edge
    /// length in the unit), so that the same surface sampled at any density is smoothed alike.
    /// Default 0.0257, 30 pairs on a canonical surface; `None` uses
    /// [`DescribeParams::smoothing_iterations`] (profiles recorded before the field existed).
    #[serde(default)]
    pub smoothing_length: Option<f64>,
    /// Harris 3D settings of the response and curvature histograms, computed on the smoothed
    /// surface (only the neighbourhood matters). Default: neighbourhoods of 0.02 unit lengths
    /// (the robust preset's, `keycomp_components::Preset::ROBUST_HARRIS_RADIUS`), whatever the
    /// detection used, so that every shape of an index is described alike.
    pub harris: keycomp_harris::HarrisParams,
    /// Geodesic radii of the patch levels, in the length unit of [`DescribeParams::units`] (see the
    /// crate documentation, *Parts*). Default 0.06, 0.09, 0.135, 0.2, 0.3, 0.45 (factor 1.5).
    pub levels: Vec<f64>,
    /// Most patches per level. Default 16 (on SHREC'07 Watertight, 6, 10 and 16 gave fragment NN
    /// 0.670, 0.760 and 0.870 for balls and 0.395, 0.430, 0.565 for scans: BENCHMARKS.md).
    pub patches_per_level: usize,
    /// Adds the whole surface as one more part. Default true.
    pub whole: bool,
    /// Length unit. Default [`Units::ScaleFree`].
    pub units: Units,
    /// Leaves out parts that reach the mesh's boundary, unless no part is complete (see
    /// *Parts*). Default false: on SHREC'07 Watertight fragments (with 6 patches per level and
    /// inverse-frequency weights) it lowered NN from 0.625 to 0.550 (balls), 0.825 to 0.730
    /// (plane cuts) and 0.395 to 0.280 (scans) (BENCHMARKS.md, *Ablation*).
    pub complete_only: bool,
    /// How far (in the length unit) the fronts from patch centres run, at least their level's
    /// radius; `None` runs every front over the whole mesh. Layout distances beyond the reach are
    /// [`NO_DISTANCE`](crate::NO_DISTANCE) (matching checks only the pairs it has), and a level's
    /// centres beyond the reach of every centre taken are chosen by Euclidean distance. Fronts from
    /// key-components and the whole surface always run over the whole mesh.
    pub layout_reach: Option<f64>,
    /// Describe a mesh of more vertices than this on a simplified proxy of about this many
    /// (the one detection's fronts ran on when it has the same budget; crate documentation,
    /// *Proxy*). Default 0: every mesh on its own vertices (a 10,000-vertex proxy makes
    /// description 2–4× cheaper on large meshes but loses retrieval, BENCHMARKS.md,
    /// *Ablations*); at least `keycomp_components::GeodesicOptions::MIN_PROXY_VERTICES`
    /// otherwise.
    #[serde(default)]
    pub proxy_vertices: usize,
}

impl Default for DescribeParams {
    fn default() -> Self {
        DescribeParams {
            smoothing_iterations: 30,
            smoothing_length: Some(keycomp_components::Preset::ROBUST_SMOOTHING_LENGTH),
            harris: keycomp_harris::HarrisParams {
                neighborhood: keycomp_harris::Neighborhood::Adaptive {
                    radius_fraction: keycomp_components::Preset::ROBUST_HARRIS_RADIUS,
                },
                length_reference: keycomp_harris::LengthReference::Unit,
                ..keycomp_harris::HarrisParams::default()
            },
            levels: vec![0.06, 0.09, 0.135, 0.2, 0.3, 0.45],
            patches_per_level: 16,
            whole: true,
            units: Units::ScaleFree,
            complete_only: false,
            layout_reach: None,
            proxy_vertices: 0,
        }
    }
}

/// Factors on a scale-free fragment query's patch radii, one per scale hypothesis
/// ([`DescribeParams::for_query`]): one and two steps of the default ladder of radii.
pub const FRAGMENT_LEVEL_FACTORS: [f64; 2] = [1.5, 2.25];

impl DescribeParams {
    /// The parameters a query `mesh` is described with against shapes described with `self`:
    /// one set, or one per scale hypothesis (the query is then ranked under each, and each
    /// shape keeps its best score: `keycomp_retrieval::rank_hypotheses`).
    ///
    /// Scale-free, every mesh is scaled to unit area on its own, so a fragment that keeps the
    /// share f of its source's area is magnified by 1/√f against its source: 1.3 to 2.2 for
    /// f from 60 % down to 20 %. Its patches of radius r cover what patches of radius r·√f
    /// cover on the source, so its smallest level holds patches smaller than any of the
    /// source's and the source's largest levels have no counterpart. A query with a boundary
    /// (a fragment, a scan) is therefore described with its radii multiplied by each of
    /// [`FRAGMENT_LEVEL_FACTORS`] (1/√f for f = 44 % and 20 %; steps of the default ladder,
    /// so most of its radii are the collection's, and a shape with holes queried whole still
    /// meets its own patches). A closed mesh, and every mesh in file units (where a fragment
    /// keeps its source's scale), is described with `self`.
    pub fn for_query(&self, mesh: &Mesh) -> Vec<DescribeParams> {
        self.for_query_with_boundary(!Topology::new(mesh).boundary_vertices().is_empty())
    }

    /// [`DescribeParams::for_query`] for a query that has a boundary or not (as an index
    /// record says, `boundary_vertices > 0`).
    pub fn for_query_with_boundary(&self, boundary: bool) -> Vec<DescribeParams> {
        match self.units {
            Units::ScaleFree if boundary => FRAGMENT_LEVEL_FACTORS
                .iter()
                .map(|f| DescribeParams {
                    levels: self.levels.iter().map(|r| r * f).collect(),
                    ..self.clone()
                })
                .collect(),
            _ => vec![self.clone()],
        }
    }
}

/// Most patch levels [`describe_with`](crate::describe_with) accepts.
pub const MAX_LEVELS: usize = 12;
/// Most patches per level [`describe_with`](crate::describe_with) accepts.
pub const MAX_PATCHES_PER_LEVEL: usize = 64;
/// Most smoothing iterations [`describe_with`](crate::describe_with) accepts.
pub const MAX_SMOOTHING_ITERATIONS: usize = 1000;
