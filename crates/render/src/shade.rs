//! Shading and resolve pass: for every sample the visibility buffer covers, interpolate the
//! vertex colours (and, for smooth shading, the vertex normals) barycentrically, light it,
//! mark outline samples, then average each pixel's samples over the background, in parallel
//! over image rows.

use rayon::prelude::*;

use crate::image::Image;
use crate::params::{Outline, RenderParams, Shading};
use crate::raster::{NONE, Plane, VisBuffer};

/// Everything the shading pass needs about the projected mesh.
pub(crate) struct Scene<'a> {
    /// Triangles as vertex ids.
    pub faces: &'a [[u32; 3]],
    /// Snapped sample coordinates of each vertex (the ones the rasteriser used).
    pub screen: Vec<[f64; 2]>,
    /// Per-vertex sRGB colours.
    pub colors: &'a [[u8; 3]],
    /// Unit face normals in the view frame `[right, up, toward]`, turned towards the viewer.
    pub face_normal: Vec<[f32; 3]>,
    /// Whether each face's own (counter-clockwise) normal points towards the viewer.
    pub front: Vec<bool>,
    /// Unit area-weighted vertex normals in the view frame (smooth shading only).
    pub vertex_normal: Option<Vec<[f32; 3]>>,
    /// Depth plane of each face (`None` for faces degenerate on screen).
    pub planes: Vec<Option<Plane>>,
}

/// Direction to the key light in the view frame: upper left, in front.
const KEY_LIGHT: [f32; 3] = [-0.45, 0.55, 0.70];

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(v: [f32; 3]) -> Option<[f32; 3]> {
    let n = dot(v, v).sqrt();
    (n > 0.0 && n.is_finite()).then(|| [v[0] / n, v[1] / n, v[2] / n])
}

/// Outline settings converted to samples.
struct OutlineSamples {
    color: [f32; 3],
    /// Reach of the silhouette test (the line is drawn on the nearer side only).
    silhouette: usize,
    /// Reach of the crease test (drawn on both sides).
    crease: usize,
    cos_crease: f32,
    gap: f64,
}

impl OutlineSamples {
    fn new(o: &Outline, ss: u32, gap: f64) -> OutlineSamples {
        let w = o.width * ss as f64;
        OutlineSamples {
            color: o.color.map(f32::from),
            silhouette: (w.round() as usize).max(1),
            crease: ((w / 2.0).round() as usize).max(1),
            cos_crease: o.crease_angle_deg.to_radians().cos() as f32,
            gap,
        }
    }
}

/// Shades the visibility buffer and downsamples it to a `size × size` image.
/// `gap` is the outline's depth gap in samples.
pub(crate) fn resolve(
    vis: &VisBuffer,
    scene: &Scene<'_>,
    params: &RenderParams,
    gap: f64,
) -> Image {
    let size = params.size as usize;
    let ss = params.supersampling as usize;
    let key = normalize(KEY_LIGHT).unwrap_or([0.0, 0.0, 1.0]);
    let outline = params
        .outline
        .as_ref()
        .map(|o| OutlineSamples::new(o, params.supersampling, gap));
    let bg = params.background;
    let bg_alpha = f32::from(bg[3]) / 255.0;
    let bg_premul = [bg[0], bg[1], bg[2]].map(|c| f32::from(c) * bg_alpha);
    let inv_n = 1.0 / (ss * ss) as f32;

    let mut pixels = vec![[0u8; 4]; size * size];
    pixels
        .par_chunks_mut(size)
        .enumerate()
        .for_each(|(py, row)| {
            for (px, out) in row.iter_mut().enumerate() {
                let mut sum = [0.0f32; 3];
                let mut alpha = 0.0f32;
                for sy in 0..ss {
                    for sx in 0..ss {
                        let (i, j) = (px * ss + sx, py * ss + sy);
                        let f = vis.face[j * vis.width + i];
                        if f == NONE {
                            for k in 0..3 {
                                sum[k] += bg_premul[k];
                            }
                            alpha += bg_alpha;
                            continue;
                        }
                        let edge = outline
                            .as_ref()
                            .is_some_and(|o| on_outline(vis, scene, o, i, j, f));
                        let c = match (&outline, edge) {
                            (Some(o), true) => o.color,
                            _ => shade(scene, params, key, i, j, f as usize),
                        };
                        for k in 0..3 {
                            sum[k] += c[k];
                        }
                        alpha += 1.0;
                    }
                }
                *out = if alpha > 0.0 {
                    let a = (alpha * inv_n * 255.0).round().clamp(0.0, 255.0) as u8;
                    let rgb = sum.map(|s| (s / alpha).round().clamp(0.0, 255.0) as u8);
                    [rgb[0], rgb[1], rgb[2], a]
                } else {
                    [bg[0], bg[1], bg[2], 0]
                };
            }
        });
    Image::from_pixels(params.size, params.size, pixels)
        .unwrap_or_else(|| Image::new(params.size, params.size, bg))
}

/// The lit colour of sample `(i, j)` of face `f`.
fn shade(
    scene: &Scene<'_>,
    params: &RenderParams,
    key: [f32; 3],
    i: usize,
    j: usize,
    f: usize,
) -> [f32; 3] {
    let [a, b, c] = scene.faces[f].map(|v| v as usize);
    let (p0, p1, p2) = (scene.screen[a], scene.screen[b], scene.screen[c]);
    let (x, y) = (i as f64 + 0.5 - p0[0], j as f64 + 0.5 - p0[1]);
    let (e1, e2) = (
        [p1[0] - p0[0], p1[1] - p0[1]],
        [p2[0] - p0[0], p2[1] - p0[1]],
    );
    let det = e1[0] * e2[1] - e2[0] * e1[1];
    // Barycentric coordinates, clamped to the triangle (a sample centre on an edge may fall a
    // rounding error outside).
    let (l1, l2) = if det != 0.0 {
        (
            ((x * e2[1] - e2[0] * y) / det).clamp(0.0, 1.0) as f32,
            ((e1[0] * y - x * e1[1]) / det).clamp(0.0, 1.0) as f32,
        )
    } else {
        (1.0 / 3.0, 1.0 / 3.0)
    };
    let s = l1 + l2;
    let (l1, l2) = if s > 1.0 { (l1 / s, l2 / s) } else { (l1, l2) };
    let l0 = 1.0 - l1 - l2;

    let normal = match (params.shading, &scene.vertex_normal) {
        (Shading::Smooth, Some(vn)) => {
            let (n0, n1, n2) = (vn[a], vn[b], vn[c]);
            let sign = if scene.front[f] { 1.0 } else { -1.0 };
            let n = [0, 1, 2].map(|k| sign * (l0 * n0[k] + l1 * n1[k] + l2 * n2[k]));
            normalize(n).unwrap_or(scene.face_normal[f])
        }
        _ => scene.face_normal[f],
    };
    let light = params.ambient as f32
        + params.headlight as f32 * normal[2].max(0.0)
        + params.key_light as f32 * dot(normal, key).max(0.0);
    let (c0, c1, c2) = (scene.colors[a], scene.colors[b], scene.colors[c]);
    [0, 1, 2].map(|k| {
        let base = l0 * f32::from(c0[k]) + l1 * f32::from(c1[k]) + l2 * f32::from(c2[k]);
        (base * light).min(255.0)
    })
}

/// Whether sample `(i, j)`, covered by face `f`, lies on a silhouette (a neighbour within
/// reach is background, or lies beyond `f`'s plane by more than the depth gap) or on a crease
/// (a neighbour's face normal differs by more than the crease angle).
fn on_outline(
    vis: &VisBuffer,
    scene: &Scene<'_>,
    o: &OutlineSamples,
    i: usize,
    j: usize,
    f: u32,
) -> bool {
    let w = vis.width as isize;
    let plane = &scene.planes[f as usize];
    let nf = scene.face_normal[f as usize];
    for (di, dj) in [(1isize, 0isize), (-1, 0), (0, 1), (0, -1)] {
        for d in 1..=o.silhouette as isize {
            let (ni, nj) = (i as isize + di * d, j as isize + dj * d);
            if ni < 0 || nj < 0 || ni >= w || nj >= w {
                return true;
            }
            let k = (nj * w + ni) as usize;
            let g = vis.face[k];
            if g == NONE {
                return true;
            }
            if g == f {
                continue;
            }
            if let Some(p) = plane
                && f64::from(vis.depth[k]) - p.extrapolate(ni as usize, nj as usize) > o.gap
            {
                return true;
            }
            if d as usize <= o.crease && dot(nf, scene.face_normal[g as usize]) < o.cos_crease {
                return true;
            }
        }
    }
    false
}
