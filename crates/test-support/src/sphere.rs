//! Great-circle distances between random points of the unit sphere: a geodesic-like distance
//! matrix with a known source, not exactly embeddable in the plane (for SMACOF's tests and its
//! bench).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The `k × k` row-major matrix of great-circle distances between `k` points drawn uniformly
/// on the unit sphere (normalised draws from the cube, ChaCha8 seeded with `seed`).
pub fn great_circle_matrix(k: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pts: Vec<[f64; 3]> = Vec::with_capacity(k);
    while pts.len() < k {
        let v: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>() * 2.0 - 1.0);
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.1 && n <= 1.0 {
            pts.push([v[0] / n, v[1] / n, v[2] / n]);
        }
    }
    let mut d = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..k {
            if i != j {
                let c = pts[i][0] * pts[j][0] + pts[i][1] * pts[j][1] + pts[i][2] * pts[j][2];
                d[i * k + j] = c.clamp(-1.0, 1.0).acos();
            }
        }
    }
    d
}
