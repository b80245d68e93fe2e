//! Points drawn uniformly by area on a mesh (used by the description's surface sample and by
//! the D2 and FPFH baselines of `keycomp bench retrieval`).
//!
//! A point is drawn in two steps (R. Osada, T. Funkhouser, B. Chazelle, D. Dobkin, "Shape
//! distributions", ACM Transactions on Graphics 21(4), 2002, Section 4.1):
//!
//! 1. a face with probability proportional to its area: `u₀ · A` with `u₀` uniform in [0, 1)
//!    and `A` the total area, located by binary search in the cumulative face areas
//!    (O(log F) for F faces, after an O(F) table built once);
//! 2. a uniform point of that triangle `(a, b, c)`: `(1 − √u₁)·a + √u₁(1 − u₂)·b + √u₁·u₂·c`.
//!
//! Each point takes exactly three values from the caller's random stream, in the order `u₀`,
//! `u₁`, `u₂`, so a seeded stream gives the same points every time.

use rand::Rng;

use crate::{Mesh, Point3, geometry};

/// Draws points uniformly by area on one mesh (see the [module docs](self)); built once per
/// mesh, then [`AreaSampler::sample`] any number of times.
#[derive(Debug, Clone)]
pub struct AreaSampler<'a> {
    mesh: &'a Mesh,
    cumulative: Vec<f64>,
    total: f64,
}

impl<'a> AreaSampler<'a> {
    /// The sampler of `mesh`, or `None` when its total area is zero or not finite (no face to
    /// draw, or non-finite coordinates).
    pub fn new(mesh: &'a Mesh) -> Option<AreaSampler<'a>> {
        let mut cumulative = Vec::with_capacity(mesh.num_faces());
        let mut total = 0.0;
        for a in geometry::face_areas(mesh) {
            total += a;
            cumulative.push(total);
        }
        (total > 0.0 && total.is_finite()).then_some(AreaSampler {
            mesh,
            cumulative,
            total,
        })
    }

    /// Total surface area of the mesh (file units squared).
    pub fn area(&self) -> f64 {
        self.total
    }

    /// One point uniform by area, and the face it lies on.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> (Point3<f64>, usize) {
        let u = rng.random::<f64>() * self.total;
        let f = self
            .cumulative
            .partition_point(|&c| c <= u)
            .min(self.cumulative.len() - 1);
        let [a, b, c] = self.mesh.triangle(f);
        let r1 = rng.random::<f64>().sqrt();
        let r2 = rng.random::<f64>();
        let p = a.coords * (1.0 - r1) + b.coords * (r1 * (1.0 - r2)) + c.coords * (r1 * r2);
        (Point3::from(p), f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn faces_are_drawn_in_proportion_to_their_area() {
        // two triangles of areas 1/2 and 3/2
        let mesh = Mesh {
            positions: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(10.0, 0.0, 0.0),
                Point3::new(13.0, 0.0, 0.0),
                Point3::new(10.0, 1.0, 0.0),
            ],
            faces: vec![[0, 1, 2], [3, 4, 5]],
        };
        let s = AreaSampler::new(&mesh).expect("positive area");
        assert!((s.area() - 2.0).abs() < 1e-12);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let n = 40_000;
        let mut second = 0;
        for _ in 0..n {
            let (p, f) = s.sample(&mut rng);
            second += f;
            // inside its triangle
            let (x, y) = if f == 0 {
                (p.x, p.y)
            } else {
                ((p.x - 10.0) / 3.0, p.y)
            };
            assert!(x >= -1e-12 && y >= -1e-12 && x + y <= 1.0 + 1e-12, "{p}");
            assert_eq!(p.z, 0.0);
        }
        let share = second as f64 / n as f64;
        // expected 0.75, binomial standard deviation ~0.002
        assert!((share - 0.75).abs() < 0.01, "{share}");
    }

    #[test]
    fn rejects_meshes_without_area() {
        let empty = Mesh {
            positions: vec![],
            faces: vec![],
        };
        assert!(AreaSampler::new(&empty).is_none());
        assert!(AreaSampler::new(&synth::icosphere(1, 1.0)).is_some());
    }
}
