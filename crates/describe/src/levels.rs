//! The parts a shape is described by (crate documentation, *Parts*): the detection's
//! key-components (I. Sipiran and B. Bustos, "Key-components: detection of salient regions on
//! 3D meshes", The Visual Computer 29(12), 2013), geodesic balls around its keypoints at every
//! radius of [`DescribeParams::levels`] (best response first, then the vertex farthest from
//! every centre taken), and the whole surface. With [`DescribeParams::complete_only`], parts
//! that reach the boundary are left out unless nothing else remains.
//!
//! Cost: one front per candidate centre (at most twice a level's budget), the levels in
//! parallel.

use keycomp_components::Detection;
use keycomp_mesh::Vector3;
use rayon::prelude::*;

use crate::error::DescribeError;
use crate::fronts::Fronts;
use crate::params::DescribeParams;
use crate::surface::Surface;

/// A part before description.
pub(crate) struct Part {
    pub(crate) center: u32,
    /// How far its centre's front must run (+∞: the whole mesh).
    pub(crate) reach: f64,
    pub(crate) vertices: Vec<u32>,
    pub(crate) keypoints: usize,
    pub(crate) level: u8,
}

/// The level of the whole-surface part: one past the patch levels.
pub(crate) fn whole_level(params: &DescribeParams) -> u8 {
    (params.levels.len() + 1).min(255) as u8
}

/// The parts of the prepared `surface` under `params` (crate documentation, *Parts*): the
/// key-components of `det`, the patches of every level and the whole surface, in that order; the
/// parts that reach the boundary when [`DescribeParams::complete_only`] leaves nothing else.
pub(crate) fn choose_parts(
    surface: &Surface,
    boundary: &[bool],
    det: &Detection,
    params: &DescribeParams,
    fronts: &Fronts,
) -> Result<Vec<Part>, DescribeError> {
    let n = surface.mesh.num_vertices();
    let clipped = |vs: &[u32]| params.complete_only && vs.iter().any(|&v| boundary[v as usize]);
    // parts reaching the boundary, used only when the mesh has no complete part
    let mut clipped_parts: Vec<Part> = Vec::new();
    let total: f64 = surface.areas.iter().sum();
    let mut is_keypoint = vec![false; n];
    for &k in &det.keypoints {
        is_keypoint[k as usize] = true;
    }

    let whole_level = whole_level(params);
    let mut parts: Vec<Part> = Vec::new();
    for c in &det.components {
        let p = Part {
            center: c.center,
            reach: f64::INFINITY,
            vertices: c.vertices.clone(),
            keypoints: c.keypoints.len(),
            level: 0,
        };
        if clipped(&p.vertices) {
            clipped_parts.push(p);
        } else {
            parts.push(p);
        }
    }
    if n > 0 {
        // the levels choose their centres independently of each other: in parallel
        let at = Levels {
            surface,
            boundary,
            det,
            is_keypoint: &is_keypoint,
            params,
            fronts,
        };
        let levels: Vec<(Vec<Part>, Vec<Part>)> = params
            .levels
            .par_iter()
            .enumerate()
            .map(|(l, &radius)| {
                let level = (l + 1).min(254) as u8;
                level_patches(&at, radius, level)
            })
            .collect::<Result<_, _>>()?;
        for (p, c) in levels {
            parts.extend(p);
            clipped_parts.extend(c);
        }
        if params.whole {
            // centre: the vertex nearest the area-weighted centroid
            let centroid = surface
                .mesh
                .positions
                .iter()
                .zip(&surface.areas)
                .fold(Vector3::zeros(), |acc, (p, a)| acc + p.coords * *a)
                / total.max(f64::MIN_POSITIVE);
            let center = (0..n)
                .min_by(|&a, &b| {
                    let da = (surface.mesh.positions[a].coords - centroid).norm_squared();
                    let db = (surface.mesh.positions[b].coords - centroid).norm_squared();
                    da.total_cmp(&db).then(a.cmp(&b))
                })
                .unwrap_or(0) as u32;
            let whole = Part {
                center,
                reach: f64::INFINITY,
                vertices: (0..n as u32).collect(),
                keypoints: det.keypoints.len(),
                level: whole_level,
            };
            if clipped(&whole.vertices) {
                clipped_parts.push(whole);
            } else {
                parts.push(whole);
            }
        }
    }
    if parts.is_empty() {
        // nothing complete (an open surface, a small fragment): describe what there is
        clipped_parts.sort_by_key(|p| p.level);
        parts = clipped_parts;
    }
    Ok(parts)
}

/// What every patch level reads (crate documentation, *Parts*).
struct Levels<'a> {
    surface: &'a Surface,
    boundary: &'a [bool],
    det: &'a Detection,
    /// Whether each vertex is one of the detection's keypoints.
    is_keypoint: &'a [bool],
    params: &'a DescribeParams,
    fronts: &'a Fronts<'a>,
}

/// The patches of one level of radius `radius` (level number `level`), in order, and the
/// clipped ones (crate documentation, *Parts*).
fn level_patches(
    at: &Levels,
    radius: f64,
    level: u8,
) -> Result<(Vec<Part>, Vec<Part>), DescribeError> {
    let Levels {
        surface,
        boundary,
        det,
        is_keypoint,
        params,
        fronts,
    } = *at;
    let n = surface.mesh.num_vertices();
    let clipped = |vs: &[u32]| params.complete_only && vs.iter().any(|&v| boundary[v as usize]);
    let (mut parts, mut clipped_parts) = (Vec::new(), Vec::new());
    let reach = params.layout_reach.map_or(f64::INFINITY, |r| r.max(radius));
    let mut nearest = vec![f64::INFINITY; n];
    // Euclidean distance to the nearest centre, ranking the vertices beyond the reach
    let mut euclid = vec![f64::INFINITY; n];
    let mut rejected = vec![false; n];
    let (mut chosen, mut fronts_run) = (0, 0);
    let mut candidates = det.keypoints.iter().copied();
    // a front per candidate centre; clipped candidates cost one too, so they are bounded
    while chosen < params.patches_per_level && fronts_run < 2 * params.patches_per_level {
        // keypoints best first, then the vertex farthest from every chosen centre
        let next = candidates
            .by_ref()
            .find(|&k| nearest[k as usize] >= radius && !rejected[k as usize])
            .or_else(|| {
                let far = |v: usize| {
                    if nearest[v].is_finite() || euclid[v].is_infinite() {
                        nearest[v]
                    } else {
                        reach + euclid[v]
                    }
                };
                let (v, d) = (0..n)
                    .filter(|&v| !rejected[v])
                    .map(|v| (v, far(v)))
                    .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
                (d >= radius).then_some(v as u32)
            });
        let Some(c) = next else { break };
        fronts_run += 1;
        let front = fronts.get(c, reach)?;
        // only what a front stopped at `reach` measures, whatever the cache holds
        let d = |v: usize| {
            let x = front.d[v];
            if x <= reach { x } else { f64::INFINITY }
        };
        let vertices: Vec<u32> = (0..n as u32).filter(|&v| d(v as usize) <= radius).collect();
        let part = Part {
            center: c,
            reach,
            keypoints: vertices
                .iter()
                .filter(|&&v| is_keypoint[v as usize])
                .count(),
            vertices,
            level,
        };
        if clipped(&part.vertices) {
            rejected[c as usize] = true;
            if part.vertices.len() >= 3 {
                clipped_parts.push(part);
            }
            continue;
        }
        for (v, m) in nearest.iter_mut().enumerate() {
            *m = m.min(d(v));
        }
        nearest[c as usize] = 0.0;
        if reach.is_finite() {
            let pc = surface.mesh.positions[c as usize];
            for (e, p) in euclid.iter_mut().zip(&surface.mesh.positions) {
                *e = e.min((p - pc).norm());
            }
        }
        chosen += 1;
        if part.vertices.len() >= 3 {
            parts.push(part);
        }
    }
    Ok((parts, clipped_parts))
}
