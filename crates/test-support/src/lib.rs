//! Helpers for keycomp's tests and benches, and for nothing else: a crate takes this as a
//! `[dev-dependencies]` entry only (library code cannot use it). It depends on no keycomp crate,
//! so every crate of the workspace can use it without a cycle.
//!
//! - [`shared_data`]: the research meshes in `../shared/data` (next to the workspace, never
//!   copied into it), or `None` after a skip message when they are absent;
//!   [`workspace_path`]: a relative path (a bench's argument) taken from the workspace root,
//!   since `cargo bench` and `cargo test` run in the package's folder.
//! - [`edge_path_distances`]: shortest edge-path lengths on a triangle mesh (Dijkstra), the
//!   oracle that geodesic distances are bounded by and compared against.
//! - [`median`]: the median of measurements.
//! - [`great_circle_matrix`]: great-circle distances between random points of the sphere, a
//!   distance matrix to embed.
//! - [`bench_args`]: a measurement harness's command line under `cargo bench`, or `None` (after
//!   a hint) when `cargo test --benches` or `--all-targets` runs it.

mod bench;
mod data;
mod dijkstra;
mod sphere;
mod stats;

pub use bench::{bench_args, take_number};
pub use data::{SHARED_DATA, shared_data, workspace_path, workspace_root};
pub use dijkstra::edge_path_distances;
pub use sphere::great_circle_matrix;
pub use stats::{median, quantile};
