//! Descriptors of a shape's parts, for retrieval and part-to-part matching.
//!
//! A shape is described by *parts* built on its key-components (Sipiran & Bustos,
//! "Key-components: detection of salient regions on 3D meshes", The Visual Computer 29(12), 2013):
//! each part gets one fixed-length vector of [`DIM`] numbers built from the Harris response
//! inside it, geodesic statistics around its centre, curvature and point-pair statistics, and
//! the shape gets a *layout*: the geodesic distances between its parts' centres, used to check
//! that matched parts sit in the same arrangement (`keycomp_retrieval`). The paper detects
//! key-components and does not describe them: the parts beyond the key-components, the
//! descriptor and the layout are keycomp's own (docs/method.md, *Description*).
//!
//! # Parts
//!
//! 1. **Key-components** (level 0): the components of the detection, as found.
//! 2. **Patches** (levels 1..=L): for each radius r of [`DescribeParams::levels`] (in the
//!    length unit, see [`Units`]), geodesic balls of radius r centred on the detection's
//!    keypoints, best response first, skipping a keypoint closer than r to a centre already
//!    taken, then (when the keypoints run out) on the vertex farthest from every centre, up to
//!    [`DescribeParams::patches_per_level`] per level. The radii form a geometric series
//!    (factor 1.5), so a fragment scaled to its own unit area still finds, one or two levels
//!    lower, patches of the size of the whole shape's; the descriptors are scale-free, so parts
//!    of different levels are compared directly and the layout check estimates the scale. A
//!    query with a boundary is described one and two steps up the ladder, two scale
//!    hypotheses ([`DescribeParams::for_query`]), so that its radii meet the collection's at
//!    the kept fractions fragments usually have.
//! 3. **The whole surface** (level L + 1), centred on the vertex nearest the area-weighted
//!    centroid, unless [`DescribeParams::whole`] is off. Its layout distances are
//!    [`NO_DISTANCE`].
//!
//! With [`DescribeParams::complete_only`] (off by default: it made fragment retrieval worse,
//! BENCHMARKS.md), parts that reach the mesh's boundary are left out (patch centres that give
//! one are skipped, at most twice the level's budget of fronts is spent), unless the mesh has
//! no complete part at all.
//!
//! So every shape with at least one vertex has parts, whether or not the detection found
//! key-components, and a shape has tens of them instead of the detection's 0–5.
//!
//! # Smoothing
//!
//! Every descriptor is measured on a smoothed copy of the surface (the shape in its length
//! unit, then [`DescribeParams::smoothing_iterations`] = 30 Taubin λ|μ pairs, [`smooth`]), with
//! the Harris fit recomputed there; key-components' vertices, the keypoints and the centres
//! come from the detection on the surface as it is. Per-vertex responses and normals are what
//! Gaussian noise scrambles, and noise lengthens geodesics: described on the raw surface,
//! corresponding components under the benchmark's noise (strength 3) were as far apart as
//! unrelated ones (median 0.91 vs 0.99); on the smoothed copy 0.28 vs 0.53 (BENCHMARKS.md,
//! *Descriptors under the benchmark transformations*, measured with the 32-value descriptor of
//! version 2). Smoothing before measuring is a choice of ours, not the paper's (the paper does
//! not describe components).
//!
//! # Proxy
//!
//! With [`DescribeParams::proxy_vertices`] = N > 0 (off by default), a mesh of more than N
//! vertices is described on a simplified proxy of about N: the one detection's fronts ran on
//! (`keycomp_components::Proxy`, half-edge collapses with the keypoints protected, survivors at
//! their input positions) when it has the same budget, else the same simplification made
//! anew, so detection and description can share one. The parts are chosen and described there
//! and lifted back to the input's vertex ids (a patch holds the input vertices whose nearest
//! survivor along the edges is in it; a key-component keeps its own vertices). It bounds
//! description's cost on meshes of any size (at N = 10,000, 0.25–0.5 of detection's time on
//! meshes of 28,000–60,000 vertices instead of 1.2×), but it is not the default: a source
//! described on a coarser surface than its fragments no longer matches them (TOSCA's scan
//! fragments, whose sources have about 25,000 vertices: NN 0.833 → 0.639; BENCHMARKS.md,
//! *Ablations*).
//!
//! Cost: 60 smoothing passes over the described surface (the mesh or its proxy), a Harris fit
//! per vertex, one fast-marching front per distinct part centre (parts of several levels often
//! share one; each kept for the layout, |V| `f64`: 80 kB per front at 10,000 vertices; the
//! parameters are bounded by [`MAX_LEVELS`], [`MAX_PATCHES_PER_LEVEL`] and
//! [`MAX_SMOOTHING_ITERATIONS`]), plus linear passes over each part's vertices and [`PAIRS`]
//! draws per part. The levels choose their centres in parallel and the parts' fronts and
//! descriptors are computed in parallel (rayon); a front asked for by two threads runs once,
//! and the result does not depend on the thread count.
//!
//! # Layout
//!
//! One module per step, in the order they run:
//!
//! - `params`: [`DescribeParams`], [`Units`] and the bounds on the work they ask for;
//! - `proxy`: the simplified proxy a large mesh is described on, and the way back to its
//!   vertex ids;
//! - `surface`: the described surface (scaled to the length unit, smoothed, its Harris fits,
//!   normals, curvatures and vertex areas);
//! - `fronts`: geodesic fronts from part centres, computed once per centre and shared;
//! - `levels`: the parts: key-components, patches level by level, the whole surface;
//! - `descriptor`: one part's [`Descriptor`] (bin by bin in its documentation);
//! - `description`: the steps in order for a shape ([`describe_with`], [`describe_all`]), the
//!   layout and the surface sample ([`ShapeDescription`]);
//! - `error`: [`DescribeError`].

mod description;
mod descriptor;
mod error;
mod fronts;
mod levels;
mod params;
mod proxy;
mod surface;

pub use description::{
    ComponentDescription, NO_DISTANCE, SAMPLE_POINTS, SAMPLE_SEED, ShapeDescription, describe,
    describe_all, describe_with,
};
pub use descriptor::{
    DESCRIPTOR_VERSION, DIM, Descriptor, HISTOGRAMS, PAIRS, SCALAR_WEIGHT, SIZE_WEIGHT, distance,
};
pub use error::DescribeError;
pub use params::{
    DescribeParams, FRAGMENT_LEVEL_FACTORS, MAX_LEVELS, MAX_PATCHES_PER_LEVEL,
    MAX_SMOOTHING_ITERATIONS, Units,
};

/// Taubin λ|μ smoothing (`keycomp_mesh::smooth`), with which the described surface is smoothed
/// (see *Smoothing*).
pub use keycomp_mesh::smooth;
