//! Kinds that move vertices and keep the connectivity (identity map): `noise`, `shotnoise`,
//! `scale`, `localscale`.
//!
//! noise: p += σ·g with g a standard normal 3-vector per vertex (Box–Muller), σ = 0.001·S·L.
//! shotnoise: shuffle the referenced vertices, move the first max(S, round(0.01·S·|V|)) along
//! their area-weighted normal by ±0.02·L. scale: p ← c + f·(p − c), c the area-weighted
//! centroid, f from [`SCALE_FACTORS`]. localscale: Dijkstra ball of radius r = 0.04·S·L around a
//! random vertex, p ← c + (1 + (1.5 − 1)·w(d))·(p − c) with c the ball's area-weighted
//! centroid, d the graph-geodesic distance to the centre vertex, w(d) = 1 for d ≤ r/2 and
//! 1 − smoothstep((d − r/2)/(r/2)) beyond. All O(|V|) except localscale, O(|V| log |V|).
//! L = √(surface area).

use keycomp_mesh::{Point3, VertexId};
use rand::Rng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{Context, Transformed, vertex_normals, weighted_centroid};
use crate::error::BenchError;
use crate::graph::dijkstra;

/// Noise σ per strength step, in units of L.
const NOISE_STEP: f64 = 0.001;
/// Fraction of vertices hit by shot noise per strength step.
const SHOT_FRACTION_STEP: f64 = 0.01;
/// Shot-noise displacement, in units of L.
const SHOT_MAGNITUDE: f64 = 0.02;
/// Global scale factor per strength 1..=5 (ordered by |ln f|).
pub(super) const SCALE_FACTORS: [f64; 5] = [0.75, 1.5, 0.5, 2.0, 4.0];
/// Local-scale radius per strength step, in units of L.
const LOCAL_RADIUS_STEP: f64 = 0.04;
/// Local-scale factor at the centre of the region.
const LOCAL_FACTOR: f64 = 1.5;

/// A standard normal sample (Box–Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    // 1 − u ∈ (0, 1] keeps the logarithm finite
    let u: f64 = 1.0 - rng.random::<f64>();
    let v: f64 = rng.random::<f64>();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

pub(super) fn noise(ctx: &Context, rng: &mut ChaCha8Rng) -> Result<Transformed, BenchError> {
    let sigma = NOISE_STEP * f64::from(ctx.s) * ctx.unit;
    let positions = ctx
        .null
        .positions
        .iter()
        .map(|p| {
            let g = nalgebra::Vector3::new(gaussian(rng), gaussian(rng), gaussian(rng));
            p + g * sigma
        })
        .collect();
    ctx.moved(positions)
}

pub(super) fn shotnoise(ctx: &Context, rng: &mut ChaCha8Rng) -> Result<Transformed, BenchError> {
    let normals = vertex_normals(ctx.null);
    let mut order = ctx.referenced();
    order.shuffle(rng);
    // draw every sign so a vertex's sign does not depend on the strength
    let signs: Vec<f64> = order
        .iter()
        .map(|_| if rng.random::<bool>() { 1.0 } else { -1.0 })
        .collect();
    let s = usize::from(ctx.s);
    let count = s
        .max((SHOT_FRACTION_STEP * s as f64 * order.len() as f64).round() as usize)
        .min(order.len());
    let mut positions = ctx.null.positions.clone();
    let magnitude = SHOT_MAGNITUDE * ctx.unit;
    for (&v, sign) in order.iter().zip(&signs).take(count) {
        positions[v as usize] += normals[v as usize] * (sign * magnitude);
    }
    ctx.moved(positions)
}

pub(super) fn scale(ctx: &Context) -> Result<Transformed, BenchError> {
    let f = SCALE_FACTORS[usize::from(ctx.s) - 1];
    let areas = ctx.vertex_areas();
    let c = weighted_centroid(ctx.null, &areas, 0..ctx.null.num_vertices() as VertexId);
    let positions = ctx.null.positions.iter().map(|p| c + (p - c) * f).collect();
    ctx.moved(positions)
}

pub(super) fn localscale(ctx: &Context, rng: &mut ChaCha8Rng) -> Result<Transformed, BenchError> {
    let referenced = ctx.referenced();
    let centre = referenced[rng.random_range(0..referenced.len())];
    let r = LOCAL_RADIUS_STEP * f64::from(ctx.s) * ctx.unit;
    let topo = ctx.topology();
    let mut ball: Vec<(VertexId, f64)> = Vec::new();
    dijkstra(&ctx.null.positions, &topo, &[(centre, 0)], r, |v, d, _| {
        ball.push((v, d));
        true
    });
    let areas = ctx.vertex_areas();
    let c = weighted_centroid(ctx.null, &areas, ball.iter().map(|&(v, _)| v));
    let mut positions = ctx.null.positions.clone();
    for &(v, d) in &ball {
        let w = falloff(d, r);
        let p: Point3<f64> = positions[v as usize];
        positions[v as usize] = c + (p - c) * (1.0 + (LOCAL_FACTOR - 1.0) * w);
    }
    ctx.moved(positions)
}

/// 1 up to r/2, smoothstep down to 0 at r.
fn falloff(d: f64, r: f64) -> f64 {
    let h = 0.5 * r;
    if d <= h {
        1.0
    } else {
        let t = ((d - h) / h).clamp(0.0, 1.0);
        1.0 - t * t * (3.0 - 2.0 * t)
    }
}
