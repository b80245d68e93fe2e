//! Approximate nearest-neighbour search over component descriptors: an inverted file with a
//! two-level k-means quantiser and quantised residuals (the IVFADC scheme of H. Jégou,
//! M. Douze and C. Schmid, "Product quantization for nearest neighbor search", IEEE TPAMI
//! 33(1), 2011, Section IV, with a scalar quantiser of the residuals instead of a product
//! quantiser, and the best re-ranked by a finer code, as in H. Jégou, R. Tavenard, M. Douze
//! and L. Amsaleg, "Searching in one billion vectors: re-rank with source coding", ICASSP
//! 2011).
//!
//! Why: an exact search of `n` 64-value descriptors reads all of them for every query part,
//! and a KD-tree is little better than a scan at 64 dimensions. The inverted file reads a few
//! thousand codes per query part instead, and no descriptor, so that an index larger than
//! memory is searched from the inverted file alone.
//!
//! The parts, one file each:
//! - [`build`]: the descriptors split into `c` coarse cells by k-means ([`crate::kmeans`]),
//!   each coarse cell into `c` fine cells by k-means over its members, with
//!   `c ≈ √(n / CELL_SIZE)` so that a fine cell holds about [`CELL_SIZE`](build::CELL_SIZE)
//!   descriptors; each descriptor stored once, in its fine cell, as the code of its residual
//!   from the fine centroid;
//! - [`quantiser`]: the code, two bytes per value (128 bytes for 64 values instead of 256),
//!   each value rounded to the nearest of 65,536 levels spanning that value's range over the
//!   cell's members, kept as two arrays (first bytes, second bytes); the distances from a
//!   query to a code by its first bytes (asymmetric distances, Jégou et al. Section III.A), by
//!   the whole code, and to a cell's box (the points its codes can stand for);
//! - [`lists`]: the inverted file itself, [`Ivf`]: centroids, each fine cell's items (its
//!   inverted list) and their codes;
//! - [`search`]: the fine cells of the nearest coarse cells scanned nearest box first, until a
//!   box is farther than the [`RERANK`]` × k`-th nearest code found (the branch-and-bound
//!   search of K. Fukunaga and P. M. Narendra, "A branch and bound algorithm for computing
//!   k-nearest neighbors", IEEE Trans. Computers C-24(7), 1975, with boxes for its bounds);
//!   the best re-ranked by their whole codes;
//! - [`settle`]: the few candidates whose distances are too close to the `k`-th place to tell
//!   apart by their codes are told apart by their descriptors;
//! - [`cache`]: the inverted file written to and read from the search cache, and extended with
//!   the records added since it was written.
//!
//! A true neighbour is missed when it lies in a cell not examined, or when rounding puts it
//! beyond the re-ranked ones, so recall is measured, not guaranteed ([`SearchEffort`] trades
//! speed for it; BENCHMARKS.md, *The index at scale*). Everything is deterministic: initial
//! centroids are evenly spaced sample points, and every sum is taken in a fixed order whatever
//! the thread count.

mod build;
mod cache;
mod lists;
mod quantiser;
mod search;
mod settle;

pub(crate) use build::{Flat, Points};
pub(crate) use cache::Origin;
pub(crate) use lists::Ivf;
pub use search::{COARSE_PROBES, FINE_PROBES, FINE_SHARE, MIN_FINE_PROBES, RERANK, SearchEffort};
pub(crate) use settle::Settle;
