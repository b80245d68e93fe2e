//! `holes` and `microholes`: remove vertices and every face touching them.
//!
//! holes: 1. pick 3 distinct random referenced vertices; 2. run a multi-source Dijkstra over
//! Euclidean edge lengths from them and remove vertices in order of distance until their
//! barycentric area reaches 2 %·S of the surface area (so the three holes have equal radius);
//! 3. drop faces touching a removed vertex and compact. O(|V| log |V|).
//!
//! microholes: 1. shuffle the referenced vertices; 2. take them in that order, skipping any
//! within 2 edges of one already taken (so two stars never touch and holes never merge), until
//! max(10·S, ⌈0.002·S·|V|⌉) are taken (fewer if the mesh runs out); 3. drop faces touching them
//! and compact. O(|V|).

use keycomp_mesh::VertexId;
use rand::Rng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{Context, Transformed};
use crate::error::BenchError;
use crate::graph::dijkstra;

/// Number of big holes.
const HOLES: usize = 3;
/// Removed area per strength step, as a fraction of the surface area.
const HOLE_AREA_STEP: f64 = 0.02;
/// Micro-holes per strength step, as a fraction of the referenced vertices.
const MICRO_FRACTION_STEP: f64 = 0.002;
/// Minimum micro-holes per strength step.
const MICRO_MIN_STEP: usize = 10;

pub(super) fn holes(ctx: &Context, rng: &mut ChaCha8Rng) -> Result<Transformed, BenchError> {
    let null = ctx.null;
    let topo = ctx.topology();
    let referenced = ctx.referenced();
    let areas = ctx.vertex_areas();
    let total: f64 = areas.iter().sum();
    let target = HOLE_AREA_STEP * f64::from(ctx.s) * total;
    let mut centres: Vec<(VertexId, u32)> = Vec::with_capacity(HOLES);
    // draw a fixed number of times so the sequence does not depend on collisions
    for label in 0..HOLES as u32 {
        let v = referenced[rng.random_range(0..referenced.len())];
        if centres.iter().all(|&(c, _)| c != v) {
            centres.push((v, label));
        }
    }
    let mut removed = vec![false; null.num_vertices()];
    let mut area = 0.0;
    dijkstra(
        &null.positions,
        &topo,
        &centres,
        f64::INFINITY,
        |v, _, _| {
            removed[v as usize] = true;
            area += areas[v as usize];
            area < target
        },
    );
    let faces = null
        .faces
        .iter()
        .copied()
        .filter(|f| !f.iter().any(|&v| removed[v as usize]))
        .collect();
    ctx.compacted(faces)
}

pub(super) fn microholes(ctx: &Context, rng: &mut ChaCha8Rng) -> Result<Transformed, BenchError> {
    let null = ctx.null;
    let topo = ctx.topology();
    let mut order = ctx.referenced();
    let n = order.len();
    let s = usize::from(ctx.s);
    let count = (MICRO_MIN_STEP * s)
        .max((MICRO_FRACTION_STEP * s as f64 * n as f64).ceil() as usize)
        .min(n / 4);
    order.shuffle(rng);
    let mut blocked = vec![false; null.num_vertices()];
    let mut removed = vec![false; null.num_vertices()];
    let mut mark = vec![false; null.num_vertices()];
    let mut ring = Vec::new();
    let mut taken = 0;
    for &v in &order {
        if taken == count {
            break;
        }
        if blocked[v as usize] {
            continue;
        }
        removed[v as usize] = true;
        taken += 1;
        topo.rings(v, 2, &mut mark, &mut ring);
        for &w in &ring {
            blocked[w as usize] = true;
        }
    }
    let faces = null
        .faces
        .iter()
        .copied()
        .filter(|f| !f.iter().any(|&v| removed[v as usize]))
        .collect();
    ctx.compacted(faces)
}
