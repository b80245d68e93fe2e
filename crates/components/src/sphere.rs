//! Smallest enclosing sphere (o, r) of a 3-D point set: the size of a key-component (the
//! paper's Section 3.3: the smallest sphere containing every keypoint of a cluster). The
//! robust preset replaces it by [`spread_sphere`] (mean and RMS distance, O(n); see
//! [`SphereRule`]); the rest of this documentation is about the enclosing sphere.
//!
//! Welzl's algorithm in its move-to-front form, written as loops whose nesting depth is the size
//! of the support set (at most 4), so there is no recursion on the number of points. With
//! `mb(P, S)` the smallest sphere containing `P` with `S` on its boundary:
//! 1. Validate; translate the points so the centre of their bounding box is the origin (smaller
//!    numbers, less cancellation). All coincident: radius 0.
//! 2. Shuffle the points with a fixed-seed ChaCha8 generator (deterministic, and expected linear
//!    time whatever the input order).
//! 3. `mtf(n, S)`: start from the sphere through `S` (empty when `S = ∅`); for `i = 0..n`, if
//!    point `p_i` lies outside (beyond a tolerance of `1e-10 ×` the point set's extent), replace
//!    the sphere by `mtf(i, S ∪ {p_i})` and move `p_i` to the front of the list. When
//!    `|S| = 4` the sphere is fixed. The answer is `mtf(|P|, ∅)`.
//! 4. The sphere through a support set: 1 point → radius 0; 2 → the diametral sphere;
//!    3 (`a, b, c`; `u = b − a`, `v = c − a`, `w = u × v`) → the circumcircle,
//!    `o = a + (|u|²·(v × w) + |v|²·(w × u)) / (2|w|²)`, or, when the three are collinear
//!    (`|w|² ≤ 1e-20·|u|²|v|²`), the diametral sphere of the farthest pair;
//!    4 (`u, v, w` from `a`) → the circumsphere,
//!    `o = a + (|u|²·(v × w) + |v|²·(w × u) + |w|²·(u × v)) / (2·u·(v × w))`, or, when the four
//!    are (nearly) coplanar (`|u·(v × w)| ≤ 1e-10·|u||v||w|`), the smallest of the spheres
//!    through 2 or 3 of them that contains all four.
//! 5. Safety: the radius is raised to the largest distance from the centre to any point, so the
//!    sphere contains every input point exactly (in floating point), whatever rounding did.
//!
//! Complexity: expected O(n) time after the shuffle, O(n) memory; recursion depth ≤ 4.
//!
//! Reference: E. Welzl, "Smallest enclosing disks (balls and ellipsoids)", in *New Results and
//! New Trends in Computer Science*, LNCS 555, Springer, 1991, pp. 359–370; the move-to-front
//! heuristic as described there.

use keycomp_mesh::{Point3, Vector3};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use serde::{Deserialize, Serialize};

use crate::error::ComponentsError;

/// Which sphere `(o, r)` bounds a cluster's region growing (Algorithm 2 grows inside `σ·r`
/// of `o`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub enum SphereRule {
    /// The smallest sphere containing every keypoint of the cluster
    /// ([`min_enclosing_sphere`]), as in the paper (Section 3.3). Its radius is set by the two
    /// to four outermost keypoints, so one keypoint more or less at the cluster's edge changes
    /// the component's extent. Default.
    #[default]
    Enclosing,
    /// Centred at the keypoints' mean, radius `factor` times their root-mean-square distance
    /// from it ([`spread_sphere`]). Every keypoint weighs the same, so the radius moves little
    /// when one keypoint at the edge comes or goes. Outlying keypoints beyond σ·r are left
    /// outside the component (region growing reports them as missed). Not in the paper: the
    /// robust preset's choice ([`crate::Preset::Robust`]), with factor 1.2. `factor` must be
    /// finite and > 0.
    Spread {
        /// Radius over the RMS distance (unitless, > 0). For keypoints spread evenly over a
        /// flat disc of radius ρ the RMS distance is ρ/√2, so √2 ≈ 1.41 gives the disc back;
        /// lowering it tightens components around their densest part.
        factor: f64,
    },
}

impl SphereRule {
    /// Checks `factor` of [`SphereRule::Spread`].
    pub fn validate(&self) -> Result<(), ComponentsError> {
        if let SphereRule::Spread { factor } = *self
            && !(factor.is_finite() && factor > 0.0)
        {
            return Err(ComponentsError::param(
                "sphere.factor",
                factor,
                "must be a finite number > 0, e.g. 1.2",
            ));
        }
        Ok(())
    }

    /// The sphere of `points` under this rule.
    ///
    /// Errors: an empty set, or a non-finite coordinate.
    pub fn sphere(&self, points: &[Point3<f64>]) -> Result<Sphere, ComponentsError> {
        match *self {
            SphereRule::Enclosing => min_enclosing_sphere(points),
            SphereRule::Spread { factor } => spread_sphere(points, factor),
        }
    }
}

/// The sphere centred at the mean of `points` whose radius is `factor` times their
/// root-mean-square distance from it ([`SphereRule::Spread`]). O(n).
///
/// Errors: an empty set, or a non-finite coordinate.
pub fn spread_sphere(points: &[Point3<f64>], factor: f64) -> Result<Sphere, ComponentsError> {
    check_points(points)?;
    let n = points.len() as f64;
    let mean = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let ms = points
        .iter()
        .map(|p| (p.coords - mean).norm_squared())
        .sum::<f64>()
        / n;
    Ok(Sphere {
        center: Point3::from(mean),
        radius: factor * ms.sqrt(),
    })
}

/// The inputs both sphere rules accept: a non-empty set of finite points.
fn check_points(points: &[Point3<f64>]) -> Result<(), ComponentsError> {
    if points.is_empty() {
        return Err(ComponentsError::Empty { what: "point set" });
    }
    if let Some(index) = points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(ComponentsError::NonFinitePoint {
            what: "sphere point",
            index,
        });
    }
    Ok(())
}

/// A sphere: centre and radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre (the paper's `o`).
    pub center: Point3<f64>,
    /// Radius (the paper's `r`), ≥ 0.
    pub radius: f64,
}

impl Sphere {
    /// Whether `p` lies inside or on the sphere, allowing `tol` beyond the radius.
    pub fn contains(&self, p: &Point3<f64>, tol: f64) -> bool {
        (p - self.center).norm() <= self.radius + tol
    }
}

/// Seed of the fixed shuffle (any constant; fixed so results are reproducible).
const SHUFFLE_SEED: u64 = 0x5eed_ba11;

/// The smallest sphere enclosing `points` (see the module docs).
///
/// Errors: `points` is empty or has a NaN or infinite coordinate.
pub fn min_enclosing_sphere(points: &[Point3<f64>]) -> Result<Sphere, ComponentsError> {
    check_points(points)?;
    let (mut lo, mut hi) = (points[0].coords, points[0].coords);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let origin = (lo + hi) / 2.0;
    let mut pts: Vec<Vector3<f64>> = points.iter().map(|p| p.coords - origin).collect();
    let extent = pts.iter().map(|p| p.norm()).fold(0.0, f64::max);
    if extent == 0.0 {
        return Ok(Sphere {
            center: points[0],
            radius: 0.0,
        });
    }
    pts.shuffle(&mut ChaCha8Rng::seed_from_u64(SHUFFLE_SEED));
    let tol = 1e-10 * extent;
    let n = pts.len();
    let mut support = Support::default();
    let ball = mtf(&mut pts, n, &mut support, tol);
    // safety step, in the caller's coordinates so `contains(p, 0.0)` holds for every input
    let center = Point3::from(ball.center + origin);
    let radius = points
        .iter()
        .map(|p| (p - center).norm())
        .fold(0.0, f64::max);
    Ok(Sphere { center, radius })
}

/// A sphere in translated coordinates; `radius < 0` is the empty sphere.
#[derive(Debug, Clone, Copy)]
struct Ball {
    center: Vector3<f64>,
    radius: f64,
}

impl Ball {
    const EMPTY: Ball = Ball {
        center: Vector3::new(0.0, 0.0, 0.0),
        radius: -1.0,
    };

    fn contains(&self, p: &Vector3<f64>, tol: f64) -> bool {
        self.radius >= 0.0 && (p - self.center).norm() <= self.radius + tol
    }

    /// The ball centred at `center` reaching the farthest of `pts`.
    fn reaching(center: Vector3<f64>, pts: &[Vector3<f64>]) -> Ball {
        let radius = pts.iter().map(|p| (p - center).norm()).fold(0.0, f64::max);
        Ball { center, radius }
    }
}

#[derive(Debug, Default)]
struct Support {
    pts: [Vector3<f64>; 4],
    len: usize,
}

/// Move-to-front Welzl on `pts[..n]` with `support` on the boundary.
fn mtf(pts: &mut [Vector3<f64>], n: usize, support: &mut Support, tol: f64) -> Ball {
    let mut ball = ball_through(&support.pts[..support.len], tol);
    if support.len == 4 {
        return ball;
    }
    for i in 0..n {
        if !ball.contains(&pts[i], tol) {
            support.pts[support.len] = pts[i];
            support.len += 1;
            ball = mtf(pts, i, support, tol);
            support.len -= 1;
            pts[..=i].rotate_right(1);
        }
    }
    ball
}

/// The smallest ball with all of `s` (0–4 points) on its boundary, or the degenerate-case
/// fallback described in the module docs.
fn ball_through(s: &[Vector3<f64>], tol: f64) -> Ball {
    match s {
        [] => Ball::EMPTY,
        [a] => Ball {
            center: *a,
            radius: 0.0,
        },
        [a, b] => Ball::reaching((a + b) / 2.0, &[*a, *b]),
        [a, b, c] => circumcircle(*a, *b, *c).unwrap_or_else(|| farthest_pair(s)),
        [a, b, c, d] => circumsphere(*a, *b, *c, *d).unwrap_or_else(|| smallest_sub_ball(s, tol)),
        _ => Ball::reaching(s[0], s),
    }
}

fn circumcircle(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> Option<Ball> {
    let (u, v) = (b - a, c - a);
    let w = u.cross(&v);
    let (uu, vv, ww) = (u.norm_squared(), v.norm_squared(), w.norm_squared());
    // written so that a NaN (overflowing input) also counts as degenerate
    let well_posed = ww > 1e-20 * uu * vv;
    if !well_posed {
        return None;
    }
    let center = a + (v.cross(&w) * uu + w.cross(&u) * vv) / (2.0 * ww);
    Some(Ball::reaching(center, &[a, b, c]))
}

fn circumsphere(
    a: Vector3<f64>,
    b: Vector3<f64>,
    c: Vector3<f64>,
    d: Vector3<f64>,
) -> Option<Ball> {
    let (u, v, w) = (b - a, c - a, d - a);
    let vxw = v.cross(&w);
    let det = u.dot(&vxw);
    let well_posed = det.abs() > 1e-10 * u.norm() * v.norm() * w.norm();
    if !well_posed {
        return None;
    }
    let center = a
        + (vxw * u.norm_squared()
            + w.cross(&u) * v.norm_squared()
            + u.cross(&v) * w.norm_squared())
            / (2.0 * det);
    Some(Ball::reaching(center, &[a, b, c, d]))
}

/// Diametral ball of the farthest pair of `s` (first pair on ties).
fn farthest_pair(s: &[Vector3<f64>]) -> Ball {
    let mut best = (0, 0, -1.0);
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            let d = (s[i] - s[j]).norm_squared();
            if d > best.2 {
                best = (i, j, d);
            }
        }
    }
    Ball::reaching((s[best.0] + s[best.1]) / 2.0, s)
}

/// Smallest ball through 2 or 3 of the four points of `s` that contains all four (within
/// `tol`); if rounding leaves none, the one whose farthest point is nearest.
fn smallest_sub_ball(s: &[Vector3<f64>], tol: f64) -> Ball {
    let mut candidates: Vec<Ball> = Vec::with_capacity(10);
    for i in 0..4 {
        for j in i + 1..4 {
            candidates.push(Ball::reaching((s[i] + s[j]) / 2.0, &[s[i], s[j]]));
        }
        let t: Vec<Vector3<f64>> = (0..4).filter(|&k| k != i).map(|k| s[k]).collect();
        if let Some(b) = circumcircle(t[0], t[1], t[2]) {
            candidates.push(b);
        }
    }
    let containing = candidates
        .iter()
        .filter(|b| s.iter().all(|p| b.contains(p, tol)))
        .min_by(|a, b| a.radius.total_cmp(&b.radius));
    match containing {
        Some(b) => *b,
        None => candidates
            .iter()
            .map(|b| Ball::reaching(b.center, s))
            .min_by(|a, b| a.radius.total_cmp(&b.radius))
            .unwrap_or_else(|| farthest_pair(s)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix3, Vector2};
    use proptest::prelude::*;

    fn p(x: f64, y: f64, z: f64) -> Point3<f64> {
        Point3::new(x, y, z)
    }

    #[test]
    fn spread_sphere_of_a_circle_is_the_circle_scaled() {
        // 12 points evenly on a circle of radius 2 about (1, -2, 0.5) in a tilted plane: the
        // mean is the centre and every point is 2 from it, so the RMS distance is 2
        let (c, rho) = (Vector3::new(1.0, -2.0, 0.5), 2.0);
        let (u, v) = (
            Vector3::new(1.0, 1.0, 0.0).normalize(),
            Vector3::new(-1.0, 1.0, 1.0).normalize(),
        );
        let pts: Vec<Point3<f64>> = (0..12)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 12.0;
                Point3::from(c + rho * (a.cos() * u + a.sin() * v))
            })
            .collect();
        for factor in [0.5, 1.2, std::f64::consts::SQRT_2] {
            let s = spread_sphere(&pts, factor).unwrap();
            assert!((s.center.coords - c).norm() < 1e-12, "{s:?}");
            assert!((s.radius - factor * rho).abs() < 1e-12, "{s:?}");
            assert_eq!(SphereRule::Spread { factor }.sphere(&pts).unwrap(), s);
        }
        // the enclosing rule is Welzl's sphere
        assert_eq!(
            SphereRule::Enclosing.sphere(&pts).unwrap(),
            min_enclosing_sphere(&pts).unwrap()
        );
    }

    #[test]
    fn spread_sphere_weighs_every_point_alike() {
        // one outlier moves the enclosing sphere's radius by half its distance, the spread
        // sphere's by much less
        let mut pts: Vec<Point3<f64>> = (0..30)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 30.0;
                p(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let before = (
            min_enclosing_sphere(&pts).unwrap().radius,
            spread_sphere(&pts, 1.0).unwrap().radius,
        );
        pts.push(p(2.0, 0.0, 0.0));
        let after = (
            min_enclosing_sphere(&pts).unwrap().radius,
            spread_sphere(&pts, 1.0).unwrap().radius,
        );
        assert!(after.0 / before.0 > 1.4, "{before:?} {after:?}");
        assert!(after.1 / before.1 < 1.1, "{before:?} {after:?}");
    }

    #[test]
    fn spread_sphere_edge_cases() {
        assert!(spread_sphere(&[], 1.2).is_err());
        assert!(spread_sphere(&[p(f64::NAN, 0.0, 0.0)], 1.2).is_err());
        let one = spread_sphere(&[p(1.0, 2.0, 3.0), p(1.0, 2.0, 3.0)], 1.2).unwrap();
        assert_eq!(one.center, p(1.0, 2.0, 3.0));
        assert_eq!(one.radius, 0.0);
        assert!(SphereRule::Spread { factor: 0.0 }.validate().is_err());
        assert!(SphereRule::Spread { factor: f64::NAN }.validate().is_err());
        assert!(SphereRule::Spread { factor: 1.2 }.validate().is_ok());
        assert!(SphereRule::Enclosing.validate().is_ok());
    }

    /// Brute force: the centre of the smallest enclosing sphere is the centre of the sphere
    /// through its 1–4 support points, so the smallest "farthest-point distance" over the
    /// centres of all spheres through 1–4 of the points is the answer (solved independently
    /// with nalgebra's LU).
    fn brute(pts: &[Point3<f64>]) -> f64 {
        let n = pts.len();
        let mut best = f64::INFINITY;
        let mut consider = |c: Point3<f64>| {
            let r = pts.iter().map(|q| (q - c).norm()).fold(0.0, f64::max);
            best = best.min(r);
        };
        for i in 0..n {
            consider(pts[i]);
            for j in i + 1..n {
                consider(nalgebra::center(&pts[i], &pts[j]));
                for k in j + 1..n {
                    // circumcentre in the plane of the triangle: c = a + s·u + t·v with
                    // (c − a)·u = |u|²/2, (c − a)·v = |v|²/2
                    let (a, u, v) = (pts[i], pts[j] - pts[i], pts[k] - pts[i]);
                    let m = Matrix2::new(u.dot(&u), u.dot(&v), u.dot(&v), v.dot(&v));
                    if let Some(st) = m
                        .lu()
                        .solve(&Vector2::new(u.dot(&u) / 2.0, v.dot(&v) / 2.0))
                        .filter(|_| u.cross(&v).norm() > 1e-9 * u.norm() * v.norm())
                    {
                        consider(a + u * st[0] + v * st[1]);
                    }
                    for l in k + 1..n {
                        let w = pts[l] - pts[i];
                        let m = Matrix3::from_rows(&[u.transpose(), v.transpose(), w.transpose()]);
                        if m.determinant().abs() > 1e-9 * u.norm() * v.norm() * w.norm()
                            && let Some(x) = m.lu().solve(&Vector3::new(
                                u.dot(&u) / 2.0,
                                v.dot(&v) / 2.0,
                                w.dot(&w) / 2.0,
                            ))
                        {
                            consider(a + x);
                        }
                    }
                }
            }
        }
        best
    }

    fn check(pts: &[Point3<f64>], expected: Option<f64>) -> Sphere {
        let s = min_enclosing_sphere(pts).unwrap();
        for q in pts {
            assert!(s.contains(q, 0.0), "{q:?} outside {s:?}");
        }
        let want = expected.unwrap_or_else(|| brute(pts));
        assert!(
            (s.radius - want).abs() <= 1e-9 * want.max(1e-12),
            "radius {} expected {want}",
            s.radius
        );
        s
    }

    #[test]
    fn single_point() {
        let s = check(&[p(1.0, 2.0, 3.0)], Some(0.0));
        assert_eq!(s.center, p(1.0, 2.0, 3.0));
    }

    #[test]
    fn two_points() {
        let s = check(&[p(0.0, 0.0, 0.0), p(2.0, 0.0, 0.0)], Some(1.0));
        assert!((s.center - p(1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn equilateral_triangle() {
        let h = 3f64.sqrt() / 2.0;
        let s = check(
            &[p(0.0, 0.0, 5.0), p(1.0, 0.0, 5.0), p(0.5, h, 5.0)],
            Some(1.0 / 3f64.sqrt()),
        );
        assert!((s.center - p(0.5, h / 3.0, 5.0)).norm() < 1e-12);
    }

    #[test]
    fn obtuse_triangle_uses_its_longest_side() {
        check(
            &[p(0.0, 0.0, 0.0), p(4.0, 0.0, 0.0), p(2.0, 0.5, 0.0)],
            Some(2.0),
        );
    }

    #[test]
    fn regular_tetrahedron() {
        let pts = [
            p(1.0, 1.0, 1.0),
            p(1.0, -1.0, -1.0),
            p(-1.0, 1.0, -1.0),
            p(-1.0, -1.0, 1.0),
        ];
        let s = check(&pts, Some(3f64.sqrt()));
        assert!(s.center.coords.norm() < 1e-12);
    }

    #[test]
    fn points_on_a_circle() {
        let pts: Vec<Point3<f64>> = (0..17)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 17.0;
                p(3.0 + 2.0 * a.cos(), -1.0 + 2.0 * a.sin(), 0.5)
            })
            .collect();
        let s = check(&pts, Some(2.0));
        assert!((s.center - p(3.0, -1.0, 0.5)).norm() < 1e-9);
    }

    #[test]
    fn cube_corners() {
        let mut pts = Vec::new();
        for i in 0..8 {
            pts.push(p(
                (i & 1) as f64,
                ((i >> 1) & 1) as f64,
                ((i >> 2) & 1) as f64,
            ));
        }
        let s = check(&pts, Some(3f64.sqrt() / 2.0));
        assert!((s.center - p(0.5, 0.5, 0.5)).norm() < 1e-9);
    }

    #[test]
    fn duplicates() {
        let pts = [
            p(1.0, 1.0, 1.0),
            p(1.0, 1.0, 1.0),
            p(1.0, 1.0, 1.0),
            p(3.0, 1.0, 1.0),
            p(3.0, 1.0, 1.0),
        ];
        check(&pts, Some(1.0));
        check(&[p(2.0, 2.0, 2.0); 5], Some(0.0));
    }

    #[test]
    fn collinear() {
        let pts: Vec<Point3<f64>> = [0.3, -2.0, 1.0, 4.0, 0.0, 3.9]
            .iter()
            .map(|&t| p(1.0 + t, 2.0 + 2.0 * t, -t))
            .collect();
        check(&pts, Some(3.0 * 6f64.sqrt()));
    }

    #[test]
    fn coplanar_grid() {
        let mut pts = Vec::new();
        for i in 0..5 {
            for j in 0..4 {
                pts.push(p(i as f64, j as f64, 2.0));
            }
        }
        check(&pts, Some((16.0f64 + 9.0).sqrt() / 2.0));
    }

    #[test]
    fn errors() {
        assert!(matches!(
            min_enclosing_sphere(&[]),
            Err(ComponentsError::Empty { .. })
        ));
        assert!(matches!(
            min_enclosing_sphere(&[p(0.0, 0.0, 0.0), p(f64::NAN, 0.0, 0.0)]),
            Err(ComponentsError::NonFinitePoint { index: 1, .. })
        ));
    }

    fn point_set() -> impl Strategy<Value = Vec<Point3<f64>>> {
        (
            prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 1..10),
            prop::collection::vec(0usize..10, 0..3),
            1e-3f64..1e3,
        )
            .prop_map(|(raw, dups, scale)| {
                let mut v: Vec<Point3<f64>> = raw
                    .into_iter()
                    .map(|(x, y, z)| p(x * scale + 7.0, y * scale, z * scale - 3.0))
                    .collect();
                for d in dups {
                    let q = v[d % v.len()];
                    v.push(q);
                }
                v
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        #[test]
        fn matches_brute_force(pts in point_set()) {
            let s = min_enclosing_sphere(&pts).unwrap();
            let want = brute(&pts);
            prop_assert!(pts.iter().all(|q| s.contains(q, 0.0)));
            prop_assert!((s.radius - want).abs() <= 1e-9 * want.max(1e-300),
                "radius {} brute force {}", s.radius, want);
        }

        /// Co-spherical sets (every point on the answer's boundary) and near-duplicates.
        #[test]
        fn cospherical_sets_match_brute_force(
            raw in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 2..24),
            jitter in prop::option::of(1e-12f64..1e-6),
        ) {
            let pts: Vec<Point3<f64>> = raw
                .iter()
                .enumerate()
                .filter_map(|(i, &(x, y, z))| {
                    let v = Vector3::new(x, y, z);
                    let n = v.norm();
                    (n > 1e-3).then(|| {
                        let e = jitter.map_or(0.0, |j| j * (i % 3) as f64);
                        Point3::from(v / n * (2.0 + e)) + Vector3::new(1.0, -2.0, 0.5)
                    })
                })
                .collect();
            prop_assume!(!pts.is_empty());
            let s = min_enclosing_sphere(&pts).unwrap();
            let want = brute(&pts);
            prop_assert!(pts.iter().all(|q| s.contains(q, 0.0)));
            prop_assert!((s.radius - want).abs() <= 1e-9 * want.max(1e-300),
                "radius {} brute force {}", s.radius, want);
        }

        #[test]
        fn coplanar_sets_match_brute_force(
            raw in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 1..9)
        ) {
            let pts: Vec<Point3<f64>> = raw.iter().map(|&(x, y)| p(x, y, 0.25 * x - y)).collect();
            let s = min_enclosing_sphere(&pts).unwrap();
            let want = brute(&pts);
            prop_assert!((s.radius - want).abs() <= 1e-9 * want.max(1e-300),
                "radius {} brute force {}", s.radius, want);
        }
    }
}
