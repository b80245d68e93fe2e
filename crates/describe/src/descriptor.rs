//! The descriptor of one part ([`Descriptor`], bin by bin in its documentation): area-weighted
//! histograms of the Harris response, of geodesic and Euclidean distances from the centre, of
//! normal directions, of curvature (shape index and curvedness, J. J. Koenderink and A. J. van
//! Doorn, "Surface shape and curvature scales", Image and Vision Computing 10(8), 1992), and of
//! point-pair distances and angles (D2 of R. Osada, T. Funkhouser, B. Chazelle, D. Dobkin,
//! "Shape distributions", ACM Transactions on Graphics 21(4), 2002; surflet pairs of E. Wahl,
//! U. Hillenbrand, G. Hirzinger, "Surflet-pair-relation histograms: a statistical 3D-shape
//! representation for rapid classification", 3DIM 2003), and four scalars. The key-component paper (Sipiran & Bustos 2013) detects parts and does not describe
//! them: the descriptor is keycomp's own.
//!
//! Cost: linear passes over the part's vertices and [`PAIRS`] draws.

use keycomp_mesh::Vector3;
use nalgebra::Matrix3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::levels::Part;
use crate::surface::Surface;

/// Version of the descriptor's definition: bumped whenever the same mesh and detection would give
/// other numbers, so that an index never compares descriptors made two ways (the CLI records it in
/// the index's profile). Version 3: 64 values per part, parts at several scales (see the crate
/// documentation, *Parts*); version 2 (32 values, the detection's key-components only) is no longer
/// made.
pub const DESCRIPTOR_VERSION: u32 = 3;

/// Number of values in a component descriptor.
pub const DIM: usize = 64;

/// The descriptor's histograms, as `(first, end)` entry ranges: each sums to 1 (or is all 0
/// when the part has nothing to count); the other entries (28–31) are scalars.
pub const HISTOGRAMS: [(usize, usize); 8] = [
    (0, 8),
    (8, 16),
    (16, 24),
    (24, 28),
    (32, 40),
    (40, 48),
    (48, 56),
    (56, 64),
];

/// Weight of the four scalar entries (28–31) relative to histogram bins.
pub const SCALAR_WEIGHT: f32 = 0.5;

/// Weight of entry 31 in file units, `ln(radius)`: parts of neighbouring levels (radii 1.5
/// apart) differ there by 0.3, against the 0.7 at which matching similarity reaches 0.
pub const SIZE_WEIGHT: f32 = 0.75;

/// Random point pairs drawn per part for the pair histograms (bins 48–63).
pub const PAIRS: usize = 512;

/// A part's descriptor: [`DIM`] numbers.
///
/// # The descriptor, bin by bin
///
/// Every entry but entry 31 in file units is invariant to rigid motion and to uniform scale:
/// histograms are of ratios, and the scalars are ratios of lengths or areas measured on the part
/// itself, never on the whole shape. Histograms are area-weighted (barycentric vertex areas; pairs
/// are drawn by area) and each sums to 1, so they do not depend on the tessellation's density.
///
/// | bins | what | why |
/// |---|---|---|
/// | 0–7 | Harris response (recomputed on the smoothed surface, see the crate documentation, *Smoothing*) `h/h_max` inside the part (`h_max` = its largest response), on a log scale: bin `b` holds `log10(h/h_max) ∈ [−(8−b)/2, −(7−b)/2)`, bin 0 also everything below 10⁻⁴ and `h ≤ 0` | how concentrated the salient features are: a sharp tip has a few strong responses, a textured region many similar ones |
/// | 8–15 | geodesic distance from the centre divided by the part's geodesic radius (largest such distance), 8 equal bins over [0, 1] | how area grows with distance: a disc grows linearly, a finger stays flat, a cone grows fast |
/// | 16–23 | `‖x − c‖ / d_geo(c, x)` for vertices beyond 20 % of the radius, 8 equal bins over [0, 1] | bending: 1 on a flat patch, lower the more the surface curls back (a fingertip, an ear) |
/// | 24–27 | angle between each vertex normal and the part's mean normal, 4 equal bins over [0, π] | how much the surface turns: flat, cap, tube, or wrapped |
/// | 28 | `ln(radius / √area)` of the part, shifted by `ln(1/√π)` (0 for a flat disc) | elongation along the surface |
/// | 29 | `λ2/λ1` of the part's vertex covariance | in-space elongation |
/// | 30 | `λ3/λ1` of the same | flatness (0 flat, 1 ball-like) |
/// | 31 | scale-free: keypoint density `(K_c/V_c)/(K/V)` mapped by `x/(1+x)`; file units: [`SIZE_WEIGHT`]` · ln(radius)`, the radius in the length unit | how much of the shape's saliency the part gathers; in file units, how big the part is (the one entry that is not scale-invariant, since sizes are comparable there) |
/// | 32–39 | shape index `(2/π)·atan2(κ1 + κ2, κ1 − κ2)` (Koenderink & van Doorn 1992), principal curvatures from the Harris quadratic fit (the same fit as bins 0–7) oriented by the vertex normal, 8 equal bins over [−1, 1] | the local surface type: cup, rut, saddle, ridge, cap |
/// | 40–47 | curvedness `√((κ1² + κ2²)/2)` times the part's radius, `log10` in 8 equal bins over [−2, 1] | how curved the surface is relative to the part's size |
/// | 48–55 | Euclidean distance of [`PAIRS`] area-sampled point pairs over twice the radius, 8 equal bins over [0, 1] (D2 of Osada et al. 2002, inside the part) | the part's extent in space: compact or spread |
/// | 56–63 | angle between the normals of the same pairs, 8 equal bins over [0, π] | how the part's orientations are distributed (a surflet-pair statistic, Wahl et al. 2003) |
///
/// Scalars are weighted ([`SCALAR_WEIGHT`]) so that each is worth about one histogram bin
/// difference at most. Euclidean distance between descriptors is the dissimilarity. The pairs
/// are drawn by a generator seeded by the part's centre and level: the same mesh gives the same
/// numbers.
pub type Descriptor = [f32; DIM];

fn bin(x: f64, lo: f64, hi: f64, bins: usize) -> usize {
    let t = ((x - lo) / (hi - lo) * bins as f64).floor();
    if t.is_nan() || t < 0.0 {
        0
    } else {
        (t as usize).min(bins - 1)
    }
}

fn normalise(h: &mut [f32]) {
    let s: f32 = h.iter().sum();
    if s > 0.0 {
        for x in h {
            *x /= s;
        }
    }
}

/// The descriptor of one part, its geodesic radius and its area (`d`: distances from its
/// centre).
pub(crate) fn describe_part(s: &Surface, part: &Part, d: &[f64]) -> (Descriptor, f64, f64) {
    let pos = &s.mesh.positions;
    let vs = &part.vertices;
    let center = pos[part.center as usize];
    let radius = vs
        .iter()
        .map(|&v| d[v as usize])
        .filter(|x| x.is_finite())
        .fold(0.0f64, f64::max);
    let comp_area: f64 = vs.iter().map(|&v| s.areas[v as usize]).sum();
    let h_max = vs
        .iter()
        .map(|&v| s.response[v as usize])
        .filter(|h| h.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);

    let mut desc = [0f32; DIM];
    let mut mean_normal = Vector3::zeros();
    let mut mean = Vector3::zeros();
    for &v in vs {
        let a = s.areas[v as usize];
        mean_normal += s.normals[v as usize] * a;
        mean += pos[v as usize].coords * a;
    }
    if mean_normal.norm() > 0.0 {
        mean_normal.normalize_mut();
    }
    if comp_area > 0.0 {
        mean /= comp_area;
    }
    let mut cov = Matrix3::zeros();
    for &v in vs {
        let vi = v as usize;
        let w = s.areas[vi];
        let a = w as f32;
        // Harris response, log scale relative to the part's maximum
        let h = s.response[vi];
        if h.is_finite() || !s.skip_unfitted {
            let b = if h > 0.0 && h_max > 0.0 {
                bin((h / h_max).log10(), -4.0, 0.0, 8)
            } else {
                0
            };
            desc[b] += a;
        }
        // geodesic distance from the centre, relative to the radius
        let dg = d[vi];
        if dg.is_finite() && radius > 0.0 {
            desc[8 + bin(dg / radius, 0.0, 1.0, 8)] += a;
            if dg > 0.2 * radius {
                let ratio = (pos[vi] - center).norm() / dg;
                desc[16 + bin(ratio, 0.0, 1.0 + 1e-9, 8)] += a;
            }
        }
        // normal turning
        let ang = s.normals[vi].dot(&mean_normal).clamp(-1.0, 1.0).acos();
        desc[24 + bin(ang, 0.0, std::f64::consts::PI + 1e-9, 4)] += a;
        let p = pos[vi].coords - mean;
        cov += p * p.transpose() * w;
        // curvature: shape index, and curvedness relative to the part's size
        let si = s.shape_index[vi];
        if si.is_finite() {
            desc[32 + bin(si, -1.0, 1.0 + 1e-9, 8)] += a;
        }
        let c = s.curvedness[vi] * radius;
        if c.is_finite() {
            let b = if c > 0.0 {
                bin(c.log10(), -2.0, 1.0, 8)
            } else {
                0
            };
            desc[40 + b] += a;
        }
    }
    // pair statistics over area-sampled point pairs (vertices stand for their areas)
    if comp_area > 0.0 && radius > 0.0 && vs.len() >= 2 {
        let mut cdf = Vec::with_capacity(vs.len());
        let mut acc = 0.0;
        for &v in vs {
            acc += s.areas[v as usize];
            cdf.push(acc);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(((part.center as u64) << 8) | part.level as u64);
        let draw = |rng: &mut ChaCha8Rng| {
            let x = rng.random::<f64>() * acc;
            vs[cdf.partition_point(|&c| c < x).min(vs.len() - 1)] as usize
        };
        for _ in 0..PAIRS {
            let (i, j) = (draw(&mut rng), draw(&mut rng));
            let e = (pos[i] - pos[j]).norm() / (2.0 * radius);
            desc[48 + bin(e, 0.0, 1.0 + 1e-9, 8)] += 1.0;
            let ang = s.normals[i].dot(&s.normals[j]).clamp(-1.0, 1.0).acos();
            desc[56 + bin(ang, 0.0, std::f64::consts::PI + 1e-9, 8)] += 1.0;
        }
    }
    for (lo, hi) in HISTOGRAMS {
        normalise(&mut desc[lo..hi]);
    }
    let compact = if comp_area > 0.0 && radius > 0.0 {
        (radius / comp_area.sqrt()).ln() - (1.0 / std::f64::consts::PI.sqrt()).ln()
    } else {
        0.0
    };
    let mut eig: Vec<f64> = cov.symmetric_eigenvalues().iter().copied().collect();
    eig.sort_by(|a, b| b.total_cmp(a));
    let (r21, r31) = if eig[0] > 0.0 {
        (eig[1].max(0.0) / eig[0], eig[2].max(0.0) / eig[0])
    } else {
        (0.0, 0.0)
    };
    let density = if !vs.is_empty() {
        (part.keypoints as f64 / vs.len() as f64) / (s.total_keypoints / s.vertices)
    } else {
        0.0
    };
    desc[28] = SCALAR_WEIGHT * (compact.clamp(-2.0, 2.0) / 2.0) as f32;
    desc[29] = SCALAR_WEIGHT * r21 as f32;
    desc[30] = SCALAR_WEIGHT * r31 as f32;
    desc[31] = if s.file_units {
        SIZE_WEIGHT * (radius.max(1e-6).ln().clamp(-10.0, 10.0)) as f32
    } else {
        SCALAR_WEIGHT * (density / (1.0 + density)) as f32
    };
    (desc, radius, comp_area)
}

/// Euclidean distance between two descriptors.
pub fn distance(a: &Descriptor, b: &Descriptor) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}
