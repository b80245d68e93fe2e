//! `sampling`: a real down-sampling by half-edge-collapse decimation, so the surviving vertices
//! keep their null positions and the correspondence is exact.
//!
//! The decimation is [`keycomp_mesh::simplify::decimate`] with no protected vertex: shortest
//! edge first, the endpoint with the smaller quadric error (Garland & Heckbert 1997) kept; link
//! condition, boundary and normal-flip checks keep a manifold input manifold. It stops when the
//! referenced-vertex count reaches the target (80, 60, 40, 25, 12 % for S = 1..5) or no edge can
//! be collapsed; about 0.1 s for 60k vertices.

use keycomp_mesh::simplify;

use super::{Context, Transformed};
use crate::error::BenchError;

/// Fraction of the referenced vertices kept per strength 1..=5.
pub(super) const KEEP: [f64; 5] = [0.80, 0.60, 0.40, 0.25, 0.12];

pub(super) fn sampling(ctx: &Context) -> Result<Transformed, BenchError> {
    let referenced = ctx.referenced().len();
    let target = (KEEP[usize::from(ctx.s) - 1] * referenced as f64).round() as usize;
    let faces = simplify::decimate(ctx.null, target.max(4), &[]);
    ctx.compacted(faces)
}
