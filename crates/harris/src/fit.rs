//! Least-squares fit of a quadratic height function (step 3) and the Harris response of its
//! coefficients (steps 4–5).

use std::cmp::Ordering;

use nalgebra::Vector3;

/// Columns of the design matrix: x²/2, xy, y²/2, x, y, 1, then the right-hand side z.
const COLS: usize = 7;

/// A column whose part orthogonal to the previous columns is smaller than this fraction of its
/// own norm makes the fit rank deficient (coefficients would be amplified by more than 1e9).
const RANK_TOL: f64 = 1e-9;

/// Least-squares fit of `z = p1/2·x² + p2·xy + p3/2·y² + p4·x + p5·y + p6` to points given in
/// their local frame; returns `[p1, …, p6]`.
///
/// Convention: `p1`, `p3` are the second derivatives ∂²z/∂x², ∂²z/∂y² and `p2` is ∂²z/∂x∂y, so
/// `z = a·x² + b·xy + c·y²` gives `p1 = 2a`, `p2 = b`, `p3 = 2c`.
///
/// Solved by Householder QR of the n × 6 design matrix (never the normal equations), after
/// scaling all three coordinates by the patch's largest distance from the z axis so every column
/// has magnitude about 1; the coefficients are scaled back, so the result does not depend on the
/// scaling. Returns `None` for fewer than 6 points, non-finite input, or a rank-deficient
/// design (e.g. all points on one line of the xy plane; see `RANK_TOL`).
pub fn fit_quadratic(points: &[Vector3<f64>]) -> Option<[f64; 6]> {
    let mut scratch = Vec::new();
    fit_quadratic_with(points, &mut scratch)
}

/// [`fit_quadratic`] with a caller-owned buffer (resized as needed, so one buffer serves many
/// fits without allocating).
pub(crate) fn fit_quadratic_with(points: &[Vector3<f64>], a: &mut Vec<f64>) -> Option<[f64; 6]> {
    let n = points.len();
    if n < 6 {
        return None;
    }
    let s = points
        .iter()
        .map(|p| p.x * p.x + p.y * p.y)
        .fold(0.0f64, f64::max)
        .sqrt();
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let inv = 1.0 / s;
    a.clear();
    a.resize(n * COLS, 0.0);
    // column-major: column j occupies a[j*n .. (j+1)*n]
    for (i, p) in points.iter().enumerate() {
        let (x, y, z) = (p.x * inv, p.y * inv, p.z * inv);
        a[i] = 0.5 * x * x;
        a[n + i] = x * y;
        a[2 * n + i] = 0.5 * y * y;
        a[3 * n + i] = x;
        a[4 * n + i] = y;
        a[5 * n + i] = 1.0;
        a[6 * n + i] = z;
    }
    // (a non-finite z propagates to the coefficients and is rejected at the end; a non-finite
    // x or y already made `s` non-finite)
    let mut col_norm = [0.0f64; 6];
    for (j, c) in col_norm.iter_mut().enumerate() {
        let col = &a[j * n..(j + 1) * n];
        *c = dot(col, col).sqrt();
    }
    // Householder QR, applied to the right-hand side column as well.
    let mut diag = [0.0f64; 6];
    for j in 0..6 {
        let (head, tail) = a.split_at_mut((j + 1) * n);
        let col = &mut head[j * n + j..];
        let norm = dot(col, col).sqrt();
        if norm.partial_cmp(&(RANK_TOL * col_norm[j])) != Some(Ordering::Greater) {
            return None;
        }
        let alpha = if col[0] > 0.0 { -norm } else { norm };
        // col becomes the Householder vector v = x − alpha·e1, with
        // vᵀv = ‖x‖² − x0² + (x0 − alpha)² = 2‖x‖(‖x‖ + |x0|)
        let vtv = 2.0 * norm * (norm + col[0].abs());
        col[0] -= alpha;
        for k in 0..(COLS - j - 1) {
            let other = &mut tail[k * n + j..(k + 1) * n];
            let f = 2.0 * dot(col, other) / vtv;
            for (o, v) in other.iter_mut().zip(col.iter()) {
                *o -= f * v;
            }
        }
        diag[j] = alpha;
    }
    // back substitution R p = Qᵀ z (R's strict upper part is a[k*n + i], i < k)
    let mut p = [0.0f64; 6];
    for i in (0..6).rev() {
        let mut r = a[6 * n + i];
        for (k, pk) in p.iter().enumerate().skip(i + 1) {
            r -= a[k * n + i] * pk;
        }
        p[i] = r / diag[i];
    }
    // undo the scaling: z/s = Σ p'·(monomials of x/s, y/s)
    let out = [p[0] * inv, p[1] * inv, p[2] * inv, p[3], p[4], p[5] * s];
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// Dot product with four independent partial sums (a single running sum is latency bound).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let (ac, bc) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ac
        .remainder()
        .iter()
        .zip(bc.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0f64; 4];
    for (x, y) in ac.zip(bc) {
        for i in 0..4 {
            acc[i] += x[i] * y[i];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Harris response of the fitted coefficients `p = [p1, …, p6]` (steps 4–5):
/// `A = p4² + 2p1² + 2p2²`, `B = p5² + 2p2² + 2p3²`, `C = p4·p5 + 2p1·p2 + 2p2·p3` are the
/// Gaussian-smoothed products of the derivatives of the fitted surface (σ² = 2, as in the
/// authors' code; their first release has `p4²` instead of `p5²` in B), and
/// `h = A·B − C² − k·(A + B)²`. `p6` is unused.
///
/// Invariant under rotations of the xy plane and under z → −z, so the in-plane axes and the
/// normal's sign chosen by the frame do not change it. On a sphere of curvature κ it is
/// `4κ⁴(1 − 4k)`; on a cylinder `−4kκ⁴`.
#[inline]
pub fn response_from_coefficients(p: &[f64; 6], k: f64) -> f64 {
    let [p1, p2, p3, p4, p5, _] = *p;
    let a = p4 * p4 + 2.0 * p1 * p1 + 2.0 * p2 * p2;
    let b = p5 * p5 + 2.0 * p2 * p2 + 2.0 * p3 * p3;
    let c = p4 * p5 + 2.0 * p1 * p2 + 2.0 * p2 * p3;
    a * b - c * c - k * (a + b) * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn sample(f: impl Fn(f64, f64) -> f64, xy: &[(f64, f64)]) -> Vec<Vector3<f64>> {
        xy.iter()
            .map(|&(x, y)| Vector3::new(x, y, f(x, y)))
            .collect()
    }

    #[test]
    fn oracle_recovers_an_exact_quadratic() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for scale in [1e-3, 1.0, 1e3] {
            for _ in 0..20 {
                let c: [f64; 6] = std::array::from_fn(|_| rng.random_range(-3.0..3.0));
                let (a, b, cc) = (c[0], c[1], c[2]);
                let f = |x: f64, y: f64| {
                    a * x * x + b * x * y + cc * y * y + c[3] * x + c[4] * y + c[5] * scale
                };
                let xy: Vec<(f64, f64)> = (0..25)
                    .map(|_| {
                        (
                            rng.random_range(-1.0..1.0) * scale,
                            rng.random_range(-1.0..1.0) * scale,
                        )
                    })
                    .collect();
                let p = fit_quadratic(&sample(f, &xy)).expect("well posed");
                let want = [2.0 * a, b, 2.0 * cc, c[3], c[4], c[5] * scale];
                for i in 0..6 {
                    // curvature terms scale as 1/length, p6 as length
                    let unit = [1.0 / scale, 1.0 / scale, 1.0 / scale, 1.0, 1.0, scale][i];
                    assert!(
                        (p[i] - want[i]).abs() <= 1e-9 * unit,
                        "p{} = {} want {} (scale {scale})",
                        i + 1,
                        p[i],
                        want[i]
                    );
                }
            }
        }
    }

    #[test]
    fn oracle_on_a_grid_without_linear_terms() {
        // z = a x² + b xy + c y² on a 5 × 5 grid: p1 = 2a, p2 = b, p3 = 2c, p4 = p5 = p6 = 0
        let (a, b, c) = (0.7, -1.3, 2.1);
        let xy: Vec<(f64, f64)> = (0..25)
            .map(|i| ((i % 5) as f64 * 0.1 - 0.2, (i / 5) as f64 * 0.1 - 0.2))
            .collect();
        let p = fit_quadratic(&sample(|x, y| a * x * x + b * x * y + c * y * y, &xy)).expect("ok");
        let want = [2.0 * a, b, 2.0 * c, 0.0, 0.0, 0.0];
        for i in 0..6 {
            assert!((p[i] - want[i]).abs() < 1e-9, "p{}: {:?}", i + 1, p);
        }
    }

    #[test]
    fn degenerate_patches_give_none() {
        // too few points
        let few = sample(|x, _| x, &[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]);
        assert!(fit_quadratic(&few).is_none());
        // all on the x axis: y columns vanish
        let line: Vec<(f64, f64)> = (0..10).map(|i| (i as f64, 0.0)).collect();
        assert!(fit_quadratic(&sample(|x, _| x * x, &line)).is_none());
        // all at the origin
        let dot = vec![Vector3::zeros(); 10];
        assert!(fit_quadratic(&dot).is_none());
        // non-finite
        let mut nan = sample(|x, y| x + y, &[(0.0, 0.0); 8]);
        nan[3].x = f64::NAN;
        assert!(fit_quadratic(&nan).is_none());
    }

    #[test]
    fn response_formula() {
        let k = 0.04;
        // sphere: p1 = p3 = κ → 4κ⁴(1 − 4k)
        let kappa: f64 = 3.0;
        let h = response_from_coefficients(&[kappa, 0.0, kappa, 0.0, 0.0, 5.0], k);
        assert!((h - 4.0 * kappa.powi(4) * (1.0 - 4.0 * k)).abs() < 1e-9);
        // cylinder: −4kκ⁴
        let h = response_from_coefficients(&[kappa, 0.0, 0.0, 0.0, 0.0, 0.0], k);
        assert!((h + 4.0 * k * kappa.powi(4)).abs() < 1e-9);
        // a pure slope in y: A = 0, B = p5², C = 0 → −k·p5⁴ (the p4² typo in B would give 0)
        let h = response_from_coefficients(&[0.0, 0.0, 0.0, 0.0, 2.0, 0.0], k);
        assert!((h + k * 16.0).abs() < 1e-12);
        // invariance under an in-plane rotation of the Hessian and gradient
        let (p1, p2, p3, p4, p5) = (1.3, -0.4, 0.2, 0.7, -0.9);
        let t: f64 = 0.83;
        let (c, s) = (t.cos(), t.sin());
        // H' = Rᵀ H R, g' = Rᵀ g
        let q1 = c * c * p1 + 2.0 * c * s * p2 + s * s * p3;
        let q2 = -c * s * p1 + (c * c - s * s) * p2 + c * s * p3;
        let q3 = s * s * p1 - 2.0 * c * s * p2 + c * c * p3;
        let q4 = c * p4 + s * p5;
        let q5 = -s * p4 + c * p5;
        let h0 = response_from_coefficients(&[p1, p2, p3, p4, p5, 0.0], k);
        let h1 = response_from_coefficients(&[q1, q2, q3, q4, q5, 0.0], k);
        assert!((h0 - h1).abs() < 1e-12 * h0.abs().max(1.0), "{h0} vs {h1}");
    }
}
