//! The D2 shape distribution (R. Osada, T. Funkhouser, B. Chazelle, D. Dobkin, "Shape
//! distributions", ACM Transactions on Graphics 21(4), 2002): the distribution of the Euclidean
//! distance between two random points of the surface, a global descriptor used here as the
//! classic baseline of retrieval quality.
//!
//! **Sampling.** [`D2Params::pairs`] pairs of points, each point drawn independently and
//! uniformly by area by [`AreaSampler`]: a face with probability proportional to its area
//! (binary search in the cumulative areas), then a uniform point of the triangle (from `√u₁`,
//! `u₂`, the formula given by Osada et al.). The random stream is ChaCha8 seeded with
//! [`D2Params::seed`], so a mesh always gets the same histogram.
//!
//! **Scale.** Distances are divided by their mean (one of the normalisations Osada et al.
//! compare, alignment by the mean), so the histogram does not depend on the mesh's size; it is invariant to rigid
//! motion by construction.
//!
//! **Histogram.** [`D2Params::bins`] equal bins over `[0, D2Params::range)` in units of the
//! mean; a rare larger value goes into the last bin. The counts are divided by the number of
//! pairs, so each histogram sums to 1 (a probability mass function).
//!
//! **Distance.** The L1 distance between the two histograms ([`l1`], in [0, 2]): the L1 norm of
//! the PDFs, one of the dissimilarity measures Osada et al. compare (others: χ², Bhattacharyya,
//! norms of the CDFs).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use keycomp_mesh::Mesh;

use keycomp_mesh::sample::AreaSampler;

/// Parameters of [`d2`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct D2Params {
    /// Point pairs sampled (default 2¹⁸ = 262,144; Osada et al. used 1024²).
    pub pairs: usize,
    /// Histogram bins (default 64).
    pub bins: usize,
    /// Upper end of the histogram in units of the mean distance (default 4).
    pub range: f64,
    /// Seed of the random stream (default 0).
    pub seed: u64,
}

impl Default for D2Params {
    fn default() -> D2Params {
        D2Params {
            pairs: 1 << 18,
            bins: 64,
            range: 4.0,
            seed: 0,
        }
    }
}

/// Why a D2 histogram cannot be computed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum D2Error {
    /// The mesh has no face of positive area to sample.
    #[error("the mesh has zero surface area: nothing to sample")]
    ZeroArea,
    /// Zero pairs or bins, or a range that is not positive.
    #[error("invalid D2 parameters: pairs and bins must be positive and the range above 0")]
    InvalidParams,
}

/// The D2 histogram of `mesh` (see the [module docs](self)): `params.bins` values summing to 1.
///
/// Errors: [`D2Error::ZeroArea`] for a mesh without area (or with non-finite coordinates),
/// [`D2Error::InvalidParams`].
pub fn d2(mesh: &Mesh, params: &D2Params) -> Result<Vec<f64>, D2Error> {
    let ok_range = params.range > 0.0 && params.range.is_finite();
    if params.pairs == 0 || params.bins == 0 || !ok_range {
        return Err(D2Error::InvalidParams);
    }
    let sampler = AreaSampler::new(mesh).ok_or(D2Error::ZeroArea)?;
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let dists: Vec<f64> = (0..params.pairs)
        .map(|_| {
            let (p, _) = sampler.sample(&mut rng);
            let (q, _) = sampler.sample(&mut rng);
            (p - q).norm()
        })
        .collect();
    let mean = dists.iter().sum::<f64>() / dists.len() as f64;
    if !(mean > 0.0 && mean.is_finite()) {
        return Err(D2Error::ZeroArea);
    }
    let mut hist = vec![0.0; params.bins];
    let scale = params.bins as f64 / (params.range * mean);
    for d in dists {
        let bin = ((d * scale) as usize).min(params.bins - 1);
        hist[bin] += 1.0;
    }
    let n = params.pairs as f64;
    for h in &mut hist {
        *h /= n;
    }
    Ok(hist)
}

/// L1 distance `Σ |aᵢ − bᵢ|` between two histograms of the same length (0 for identical
/// distributions, 2 for disjoint ones). Extra bins of the longer one count in full.
pub fn l1(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().max(b.len());
    (0..n)
        .map(|i| (a.get(i).copied().unwrap_or(0.0) - b.get(i).copied().unwrap_or(0.0)).abs())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::{Point3, synth};

    /// For two uniform points of a sphere of radius 1 the distance d has density d/2 on [0, 2]
    /// and mean 4/3, so x = d / mean has density (8/9)·x on [0, 3/2].
    fn analytic_sphere(params: &D2Params) -> Vec<f64> {
        let w = params.range / params.bins as f64;
        (0..params.bins)
            .map(|i| {
                let (a, b) = ((i as f64 * w).min(1.5), ((i + 1) as f64 * w).min(1.5));
                4.0 / 9.0 * (b * b - a * a)
            })
            .collect()
    }

    #[test]
    fn sphere_matches_the_analytic_density() {
        let params = D2Params::default();
        let h = d2(&synth::icosphere(5, 1.0), &params).unwrap();
        assert!((h.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        let exact = analytic_sphere(&params);
        assert!((exact.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let err = l1(&h, &exact);
        // sampling noise (~2.6e5 pairs) and the polyhedral approximation of the sphere
        assert!(err < 0.03, "L1 to the analytic density: {err}");
        // and a different shape is far from it
        let torus = d2(&synth::torus(1.0, 0.3, 64, 24), &params).unwrap();
        assert!(l1(&torus, &exact) > 5.0 * err, "{}", l1(&torus, &exact));
    }

    #[test]
    fn invariant_to_scale_and_rigid_motion() {
        let params = D2Params {
            pairs: 1 << 15,
            ..D2Params::default()
        };
        let m = synth::protrusion_sphere(3, 0.5, 0.4);
        let h = d2(&m, &params).unwrap();
        let mut scaled = m.clone();
        let shift = Point3::new(3.0, -2.0, 0.5);
        for p in &mut scaled.positions {
            // scale by 7.3, rotate 90° about z, translate
            *p = Point3::new(-7.3 * p.y, 7.3 * p.x, 7.3 * p.z) + shift.coords;
        }
        let hs = d2(&scaled, &params).unwrap();
        // the same faces are drawn (areas scale uniformly), so only rounding at bin edges differs
        assert!(l1(&h, &hs) < 1e-3, "{}", l1(&h, &hs));
    }

    #[test]
    fn deterministic_for_a_seed_and_seed_sensitive() {
        let params = D2Params {
            pairs: 1 << 14,
            ..D2Params::default()
        };
        let m = synth::torus(1.0, 0.4, 32, 16);
        assert_eq!(d2(&m, &params).unwrap(), d2(&m, &params).unwrap());
        let other = d2(&m, &D2Params { seed: 9, ..params }).unwrap();
        let same = d2(&m, &params).unwrap();
        assert_ne!(other, same);
        // another sample of the same shape is close
        assert!(l1(&other, &same) < 0.1, "{}", l1(&other, &same));
    }

    /// The D2 histogram as computed before the sampler moved to [`AreaSampler`] (the code of
    /// that version, inline): the refactor must not change a single count.
    fn d2_before_the_shared_sampler(mesh: &Mesh, params: &D2Params) -> Vec<f64> {
        use keycomp_mesh::geometry;
        use rand::Rng;
        let areas = geometry::face_areas(mesh);
        let mut cumulative = Vec::with_capacity(areas.len());
        let mut total = 0.0;
        for a in &areas {
            total += a;
            cumulative.push(total);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let sample = |rng: &mut ChaCha8Rng| {
            let u = rng.random::<f64>() * total;
            let f = cumulative.partition_point(|&c| c <= u).min(areas.len() - 1);
            let [a, b, c] = mesh.triangle(f);
            let r1 = rng.random::<f64>().sqrt();
            let r2 = rng.random::<f64>();
            a.coords * (1.0 - r1) + b.coords * (r1 * (1.0 - r2)) + c.coords * (r1 * r2)
        };
        let dists: Vec<f64> = (0..params.pairs)
            .map(|_| {
                let p = sample(&mut rng);
                let q = sample(&mut rng);
                (p - q).norm()
            })
            .collect();
        let mean = dists.iter().sum::<f64>() / dists.len() as f64;
        let mut hist = vec![0.0; params.bins];
        let scale = params.bins as f64 / (params.range * mean);
        for d in dists {
            let bin = ((d * scale) as usize).min(params.bins - 1);
            hist[bin] += 1.0;
        }
        let n = params.pairs as f64;
        for h in &mut hist {
            *h /= n;
        }
        hist
    }

    #[test]
    fn shared_sampler_keeps_the_histograms() {
        let params = D2Params {
            pairs: 1 << 16,
            seed: 5,
            ..D2Params::default()
        };
        let mut meshes = vec![
            synth::icosphere(3, 1.0),
            synth::torus(1.0, 0.3, 48, 16),
            synth::protrusion_sphere(3, 0.5, 0.4),
        ];
        // a real mesh when the shared data is present
        if let Some(real) = keycomp_test_support::shared_data("watertight/1.off") {
            match keycomp_mesh::read_mesh(&real) {
                Ok(m) => meshes.push(m.mesh),
                Err(_) => eprintln!("skipping the real mesh: {} not readable", real.display()),
            }
        }
        for m in &meshes {
            // bitwise equal, not merely close
            assert_eq!(
                d2(m, &params).unwrap(),
                d2_before_the_shared_sampler(m, &params)
            );
        }
    }

    #[test]
    fn rejects_degenerate_input() {
        let empty = Mesh {
            positions: vec![],
            faces: vec![],
        };
        assert_eq!(d2(&empty, &D2Params::default()), Err(D2Error::ZeroArea));
        let m = synth::icosphere(1, 1.0);
        let bad = D2Params {
            bins: 0,
            ..D2Params::default()
        };
        assert_eq!(d2(&m, &bad), Err(D2Error::InvalidParams));
        assert_eq!(l1(&[0.5, 0.5], &[0.5, 0.5]), 0.0);
        assert_eq!(l1(&[1.0, 0.0], &[0.0, 1.0]), 2.0);
    }
}
