//! The comparison method of Sipiran & Bustos, "Key-components: detection of salient regions on
//! 3D meshes", *The Visual Computer* 29(12), 2013, Section 4.4: diffusion-geometric maximally
//! stable components (R. Litman, A. M. Bronstein and M. M. Bronstein, "Diffusion-geometric
//! maximally stable component detection in deformable shapes", *Computers & Graphics*
//! 35(3):549–560, 2011) and the paper's **MSER key-components** (its Fig. 10: MSER
//! components, HKS keypoints, the smallest-area components covering the keypoints).
//!
//! The modules, each with its method, choices and complexity:
//! - [`tree`]: the component tree of a vertex- or edge-weighted graph, by union-find;
//! - [`stable`]: maximally stable components by the area-stability criterion, with the usual
//!   area, variation and duplicate filters;
//! - [`detect`](mod@detect): the mesh pipeline — Laplace–Beltrami spectrum
//!   ([`keycomp_spectral`]), heat-kernel weights, tree, stable components, HKS keypoints, the
//!   covering set — and its conversion to key-component detection's
//!   [`keycomp_components::Detection`].
//!
//! ```
//! use keycomp_mesh::synth;
//! use keycomp_mser::{MserParams, Output, detect};
//!
//! let mesh = synth::protrusion_sphere(4, 0.8, 0.25);
//! let det = detect(&mesh, &MserParams::default())?;
//! assert!(!det.components.is_empty());
//! let kc = det.to_detection(&mesh, Output::KeyComponents)?;
//! assert!(kc.components.len() <= det.components.len());
//! # Ok::<(), keycomp_mser::MserError>(())
//! ```

pub mod detect;
mod error;
mod method;
pub mod stable;
pub mod tree;

pub use detect::{
    MserDetection, MserParams, MserTimings, Output, Weighting, covering_set, detect, diffusion_tree,
};
pub use error::{MserError, Result};
pub use method::Method;
pub use stable::{StableComponent, StableParams, maximally_stable, variations};
pub use tree::ComponentTree;
