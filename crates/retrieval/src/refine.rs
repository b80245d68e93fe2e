//! Refining an alignment to the accuracy of the surfaces' sampling: trimmed point-to-plane ICP
//! with a uniform scale, from the alignment verification found ([`crate::verify`]), between
//! the query's points and the target's points with their normals.
//!
//! Each round pairs every query point, moved by the current transform, with its nearest target
//! point (a KD-tree), keeps the [`TRIM`] nearest pairs (trimmed ICP: D. Chetverikov, D.
//! Svirko, D. Stepanov, P. Krsek, "The trimmed iterative closest point algorithm", ICPR 2002:
//! a fragment's or a scan's points beyond the target's border find no true partner), and
//! solves the linearised point-to-plane least squares (Y. Chen and G. Medioni, "Object
//! modelling by registration of multiple range images", Image and Vision Computing 10(3),
//! 1992; K.-L. Low's linearisation, UNC TR04-004, 2004) for a small rotation ω, a relative
//! scale change δ about the moved points' centroid c and a translation τ:
//! `((x − c)×n)·ω + (n·(x − c))·δ + n·τ = −(x − q)·n` per pair (x moved query point, q its
//! target point, n its normal), then composes the update. It stops when the update is below
//! [`CONVERGED`] or after [`ROUNDS`] rounds. In file units the scale stays fixed (δ = 0); else
//! it stays within [`SCALE_DRIFT`] of the start's (a round that would leave it keeps it).
//!
//! Trimmed pairs fit a wrong pose too (a blobby shape's back fits it turned over, to the 70 %
//! kept); what tells poses apart is the share of *all* the query's points that end on the
//! surface ([`Target::on`]: within half a target spacing of a tangent plane), by which a
//! caller refining several starts keeps the best.
//!
//! Cost: O(rounds · m log n) for m query points and n target points.

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

use crate::verify::Alignment;

/// Most rounds.
pub const ROUNDS: usize = 30;
/// Share of the pairs kept each round, the nearest.
pub const TRIM: f64 = 0.7;
/// An update moving the points by less than this share of their spread ends the rounds.
pub const CONVERGED: f64 = 1e-5;
/// A moved query point is on the target when its distance to the tangent plane of its nearest
/// target point is at most this many target spacings (the median distance between
/// neighbouring target points) ...
pub const ON_PLANE: f64 = 0.5;
/// ... and that point is at most this many spacings away (not beyond the target's border).
pub const ON_REACH: f64 = 1.5;
/// Largest factor by which refinement may change the start's scale.
pub const SCALE_DRIFT: f64 = 1.25;
/// Target points probed for the target's spacing.
const SPACING_PROBES: usize = 1000;

/// A refined alignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refined {
    /// The alignment.
    pub alignment: Alignment,
    /// Root mean square of the kept pairs' point-to-plane distances, in the target's units.
    pub rms: f64,
}

fn v(p: [f64; 3]) -> Vector3<f64> {
    Vector3::new(p[0], p[1], p[2])
}

/// The surface queries are refined onto: its points with their unit normals, a KD-tree over
/// them and their spacing.
pub struct Target<'a> {
    points: &'a [[f64; 3]],
    normals: &'a [[f64; 3]],
    tree: ImmutableKdTree<f64, u32, 3, 32>,
    spacing: f64,
}

impl<'a> Target<'a> {
    /// The surface sampled by `points` with their unit `normals`; `None` for fewer than 7
    /// points or as many normals.
    pub fn new(points: &'a [[f64; 3]], normals: &'a [[f64; 3]]) -> Option<Self> {
        if points.len() < 7 || normals.len() != points.len() {
            return None;
        }
        let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(points);
        let two = std::num::NonZero::new(2).expect("2 is not 0");
        let step = (points.len() / SPACING_PROBES).max(1);
        let mut d: Vec<f64> = points
            .iter()
            .step_by(step)
            .filter_map(|x| {
                let nb = tree.nearest_n::<SquaredEuclidean>(x, two);
                nb.get(1).map(|nb| nb.distance.sqrt())
            })
            .collect();
        d.sort_by(f64::total_cmp);
        let spacing = d.get(d.len() / 2).copied().unwrap_or(0.0);
        Some(Target {
            points,
            normals,
            tree,
            spacing,
        })
    }

    /// The nearest target point to `x`, its index and the squared distance.
    fn nearest(&self, x: &Vector3<f64>) -> (f64, usize) {
        let nb = self.tree.nearest_one::<SquaredEuclidean>(&[x.x, x.y, x.z]);
        (nb.distance, nb.item as usize)
    }

    /// `start` refined so that `query` (points in the query's frame) lies on the surface, at
    /// most `rounds` rounds (see the module documentation); `fixed_scale` keeps the scale.
    /// `None` without at least 7 query points, or when the start is not finite.
    pub fn refine(
        &self,
        query: &[[f64; 3]],
        start: Alignment,
        fixed_scale: bool,
        rounds: usize,
    ) -> Option<Refined> {
        if query.len() < 7 {
            return None;
        }
        let (target, normals) = (self.points, self.normals);
        let mut r = Matrix3::from_fn(|i, j| start.rotation[i][j]);
        let mut s = start.scale;
        let mut t = v(start.translation);
        if !(s.is_finite()
            && s > 0.0
            && r.iter().all(|x| x.is_finite())
            && t.iter().all(|x| x.is_finite()))
        {
            return None;
        }
        let p: Vec<Vector3<f64>> = query.iter().map(|&x| v(x)).collect();
        let keep = ((query.len() as f64 * TRIM).ceil() as usize).clamp(7, query.len());
        let mut pairs: Vec<(f64, usize, usize)> = Vec::with_capacity(query.len());
        let mut rms = f64::NAN;
        for _ in 0..rounds {
            let moved: Vec<Vector3<f64>> = p.iter().map(|x| s * (r * x) + t).collect();
            pairs.clear();
            for (i, x) in moved.iter().enumerate() {
                let (d2, j) = self.nearest(x);
                pairs.push((d2, i, j));
            }
            pairs.select_nth_unstable_by(keep - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let kept = &pairs[..keep];
            let c = kept.iter().map(|&(_, i, _)| moved[i]).sum::<Vector3<f64>>() / keep as f64;
            let spread = (kept
                .iter()
                .map(|&(_, i, _)| (moved[i] - c).norm_squared())
                .sum::<f64>()
                / keep as f64)
                .sqrt();
            let dof = if fixed_scale { 6 } else { 7 };
            let mut ata = SMatrix::<f64, 7, 7>::zeros();
            let mut atb = SVector::<f64, 7>::zeros();
            let mut sq = 0.0;
            for &(_, i, j) in kept {
                let n = v(normals[j]);
                let x = moved[i];
                let y = x - c;
                let res = (x - v(target[j])).dot(&n);
                sq += res * res;
                let w = y.cross(&n);
                let row = SVector::<f64, 7>::from([w.x, w.y, w.z, n.x, n.y, n.z, n.dot(&y)]);
                ata += row * row.transpose();
                atb -= row * res;
            }
            rms = (sq / keep as f64).sqrt();
            // a light ridge keeps directions the points do not constrain (a flat patch's slide)
            let ridge = 1e-9 * ata.trace().max(f64::MIN_POSITIVE);
            for k in 0..dof {
                ata[(k, k)] += ridge;
            }
            let rigid = || -> Option<SVector<f64, 7>> {
                let a6 = ata.fixed_view::<6, 6>(0, 0).into_owned();
                let b6 = atb.fixed_rows::<6>(0).into_owned();
                let x6 = a6.cholesky()?.solve(&b6);
                Some(SVector::<f64, 7>::from([
                    x6[0], x6[1], x6[2], x6[3], x6[4], x6[5], 0.0,
                ]))
            };
            let x = if fixed_scale {
                rigid()?
            } else {
                // a scale leaving SCALE_DRIFT of the start's: this round keeps the scale (the
                // trimmed pairs of a shrinking query fit ever better, down to a point)
                let x = ata.cholesky()?.solve(&atb);
                let next = s * (1.0 + x[6]);
                if next > start.scale * SCALE_DRIFT || next < start.scale / SCALE_DRIFT {
                    rigid()?
                } else {
                    x
                }
            };
            let (omega, tau, delta) = (
                Vector3::new(x[0], x[1], x[2]),
                Vector3::new(x[3], x[4], x[5]),
                x[6],
            );
            let dr = *Rotation3::new(omega).matrix();
            let k = 1.0 + delta;
            // x' = k·dR·(x − c) + c + τ, x = s·R·p + t
            r = dr * r;
            s *= k;
            t = k * (dr * (t - c)) + c + tau;
            let step = omega.norm() * spread + delta.abs() * spread + tau.norm();
            if !(s.is_finite() && s > 0.0) {
                return None;
            }
            if step <= CONVERGED * spread.max(f64::MIN_POSITIVE) {
                break;
            }
        }
        // re-orthonormalise the composed rotation
        let svd = r.svd(true, true);
        let (u, vt) = (svd.u?, svd.v_t?);
        let mut r = u * vt;
        if r.determinant() < 0.0 {
            let mut d = Matrix3::identity();
            d[(2, 2)] = -1.0;
            r = u * d * vt;
        }
        Some(Refined {
            alignment: Alignment {
                rotation: std::array::from_fn(|i| std::array::from_fn(|j| r[(i, j)])),
                translation: [t.x, t.y, t.z],
                scale: s,
            },
            rms,
        })
    }

    /// The share of `query`'s points (in the query's frame) that `alignment` puts on the
    /// surface: within [`ON_PLANE`] target spacings of the tangent plane of their nearest
    /// target point, itself within [`ON_REACH`] spacings. What tells a pose from another that
    /// fits the trimmed pairs as well; 0 without points.
    pub fn on(&self, query: &[[f64; 3]], alignment: &Alignment) -> f64 {
        if query.is_empty() {
            return 0.0;
        }
        let on = query
            .iter()
            .filter(|&&x| {
                let y = v(alignment.apply(x));
                let (d2, j) = self.nearest(&y);
                d2 <= (ON_REACH * self.spacing).powi(2)
                    && (y - v(self.points[j])).dot(&v(self.normals[j])).abs()
                        <= ON_PLANE * self.spacing
            })
            .count();
        on as f64 / query.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a wavy surface z = f(x, y) with their normals.
    fn wavy(n: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let f = |x: f64, y: f64| 0.2 * (3.0 * x).sin() * (2.0 * y).cos() + 0.1 * x * y;
        let (mut p, mut nn) = (Vec::new(), Vec::new());
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (
                    2.0 * i as f64 / n as f64 - 1.0,
                    2.0 * j as f64 / n as f64 - 1.0,
                );
                let h = 1e-5;
                let fx = (f(x + h, y) - f(x - h, y)) / (2.0 * h);
                let fy = (f(x, y + h) - f(x, y - h)) / (2.0 * h);
                let nv = Vector3::new(-fx, -fy, 1.0).normalize();
                p.push([x, y, f(x, y)]);
                nn.push([nv.x, nv.y, nv.z]);
            }
        }
        (p, nn)
    }

    /// A patch of the surface moved by a known similarity and started from a transform a few
    /// degrees and a few percent off goes back to the exact one.
    #[test]
    fn a_moved_patch_is_registered_back() {
        let (target, normals) = wavy(120);
        let surface = Target::new(&target, &normals).expect("a target");
        let truth_r = Rotation3::from_euler_angles(0.4, -0.3, 0.9);
        let (truth_s, truth_t) = (0.5, Vector3::new(0.3, -0.1, 0.2));
        // the query: the patch x, y < 0.4, given in a frame where truth maps it onto target
        let query: Vec<[f64; 3]> = target
            .iter()
            .filter(|p| p[0] < 0.4 && p[1] < 0.4)
            .map(|p| {
                let y = truth_r.inverse() * ((v(*p) - truth_t) / truth_s);
                [y.x, y.y, y.z]
            })
            .step_by(3)
            .collect();
        let off = Rotation3::from_euler_angles(0.03, -0.04, 0.02) * truth_r;
        let start = Alignment {
            rotation: std::array::from_fn(|i| std::array::from_fn(|j| off.matrix()[(i, j)])),
            translation: [truth_t.x + 0.03, truth_t.y - 0.02, truth_t.z],
            scale: truth_s * 1.04,
        };
        let got = surface
            .refine(&query, start, false, ROUNDS)
            .expect("refined");
        let r = Matrix3::from_fn(|i, j| got.alignment.rotation[i][j]);
        let d = r * truth_r.matrix().transpose();
        let angle = ((d.trace() - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        assert!(angle < 0.05, "rotation off by {angle}°");
        assert!(
            (got.alignment.scale / truth_s - 1.0).abs() < 1e-3,
            "{:?}",
            got
        );
        assert!(
            (v(got.alignment.translation) - truth_t).norm() < 1e-3,
            "{:?}",
            got
        );
        assert!(got.rms < 1e-3, "{:?}", got);
        // with the scale fixed at the truth, the same
        let fixed = Alignment {
            scale: truth_s,
            ..start
        };
        let got = surface
            .refine(&query, fixed, true, ROUNDS)
            .expect("refined");
        assert_eq!(got.alignment.scale, truth_s);
        assert!(
            (v(got.alignment.translation) - truth_t).norm() < 1e-3,
            "{:?}",
            got
        );
        // too few points, or a start that is not a number, give nothing
        assert!(surface.refine(&query[..3], start, false, ROUNDS).is_none());
        let bad = Alignment {
            scale: f64::NAN,
            ..start
        };
        assert!(surface.refine(&query, bad, false, ROUNDS).is_none());
    }
}
