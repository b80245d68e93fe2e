//! The components stage of keycomp: from keypoints and their pairwise geodesic distances to
//! key-components (Sipiran & Bustos, "Key-components: detection of salient regions on 3D
//! meshes", *The Visual Computer* 29(12), 2013, Sections 3.2–3.3).
//!
//! The pure algorithms, each in its own module:
//! - [`mod@smacof`]: metric MDS of the K × K geodesic distance matrix to the plane (Eq. 1);
//! - [`cluster`]: adaptive clustering of the 2-D images (Algorithm 1);
//! - [`sphere`]: smallest enclosing sphere of a cluster's keypoints (Welzl), or the robust
//!   preset's sphere from their spread ([`SphereRule`]);
//! - [`grow`]: geodesic centre of a cluster (Eq. 2) and region growing on the mesh inside the
//!   scaled sphere (Algorithm 2);
//! - [`params`]: the stage's parameters, the paper's presets KC-1, KC-2, KC-3 and keycomp's
//!   robust preset.
//!
//! Per cluster `S_i`: `ĉ_i = geodesic_center(S_i, points2d)`, `(o_i, r_i) =
//! min_enclosing_sphere(positions of S_i)`, component = `RegionGrower::grow(ĉ_i, S_i, (o_i, r_i),
//! σ)`. All functions are deterministic for given inputs and parameters; none panics on bad
//! input: they return [`ComponentsError`].

pub mod cluster;
mod error;
pub mod grow;
pub mod params;
pub mod pipeline;
pub mod saliency;
pub mod smacof;
pub mod sphere;

pub use cluster::{Cluster, ClusterParams, Clustering, adaptive_clustering};
pub use error::ComponentsError;
pub use grow::{Component, RegionGrower, geodesic_center};
pub use params::{ComponentParams, Grouping, Preset};
pub use pipeline::{
    DetectError, DetectParams, Detection, Extracted, ExtractedComponent, GeodesicOptions,
    KeyComponent, Proxy, Timings, detect, detect_in, extract_components, geodesic_proxy,
    keypoint_distances,
};
pub use saliency::{SaliencyParams, Salient, prominent_peaks, salient_components};
pub use smacof::{Embedding, SmacofParams, UpperTriangle, smacof, smacof_upper};
pub use sphere::{Sphere, SphereRule, min_enclosing_sphere, spread_sphere};
