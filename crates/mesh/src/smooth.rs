//! Taubin λ|μ smoothing (Taubin, "A signal processing approach to fair surface design",
//! SIGGRAPH 1995): a copy of the surface with its high-frequency noise removed, on which
//! `keycomp_describe` measures its descriptors and, optionally, Harris 3D its responses.

use crate::{Mesh, Point3, Topology};
use rayon::prelude::*;

/// Shrinking step of one λ|μ pair (0 < λ < 1).
pub const LAMBDA: f64 = 0.5;
/// Inflating step of one λ|μ pair (μ < −λ; the pass-band frequency is 1/λ + 1/μ ≈ 0.11).
pub const MU: f64 = -0.53;

/// `iterations` λ|μ pairs of umbrella-operator (uniform weight) smoothing. Boundary and isolated
/// vertices stay where they are, so holes and cut rims do not shrink. Returns the smoothed
/// positions; the connectivity is that of `mesh`.
pub fn taubin(mesh: &Mesh, topo: &Topology, iterations: usize) -> Vec<Point3<f64>> {
    taubin_with(mesh, topo, iterations, true)
}

/// [`taubin`], with boundary vertices either fixed (`fix_boundary`, as [`taubin`] does) or
/// smoothed like the others, towards the mean of their neighbours. Smoothing the boundary
/// keeps the rims of small holes from standing out of a smoothed surface as ridges (which
/// Harris 3D would take for features); large holes shrink a little.
pub fn taubin_with(
    mesh: &Mesh,
    topo: &Topology,
    iterations: usize,
    fix_boundary: bool,
) -> Vec<Point3<f64>> {
    let mut p = mesh.positions.clone();
    let mut next = p.clone();
    let fixed: Vec<bool> = (0..p.len() as u32)
        .map(|v| topo.neighbors(v).is_empty() || (fix_boundary && topo.is_boundary(v)))
        .collect();
    for _ in 0..iterations {
        for step in [LAMBDA, MU] {
            next.par_iter_mut()
                .enumerate()
                .with_min_len(1024)
                .for_each(|(v, out)| {
                    if fixed[v] {
                        *out = p[v];
                        return;
                    }
                    let nb = topo.neighbors(v as u32);
                    let mut c = nalgebra::Vector3::zeros();
                    for &u in nb {
                        c += p[u as usize].coords;
                    }
                    c /= nb.len() as f64;
                    *out = p[v] + (c - p[v].coords) * step;
                });
            std::mem::swap(&mut p, &mut next);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth;

    #[test]
    fn keeps_a_sphere_a_sphere_and_removes_noise() {
        let clean = synth::icosphere(4, 1.0);
        let topo = Topology::new(&clean);
        // a deterministic jitter of about a tenth of an edge along the radius
        let mut noisy = clean.clone();
        for (i, p) in noisy.positions.iter_mut().enumerate() {
            let s = 1.0 + 0.01 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
            *p = Point3::from(p.coords * s);
        }
        let spread = |pts: &[Point3<f64>]| {
            let r: Vec<f64> = pts.iter().map(|p| p.coords.norm()).collect();
            let mean = r.iter().sum::<f64>() / r.len() as f64;
            (
                mean,
                (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt(),
            )
        };
        let (mean0, dev0) = spread(&noisy.positions);
        let smoothed = taubin(&noisy, &topo, 10);
        let (mean1, dev1) = spread(&smoothed);
        assert!(dev1 < 0.6 * dev0, "noise {dev0} -> {dev1}");
        // Taubin smoothing does not shrink like plain Laplacian smoothing
        assert!(
            (mean1 - mean0).abs() < 0.01 * mean0,
            "radius {mean0} -> {mean1}"
        );
    }

    #[test]
    fn a_free_boundary_is_smoothed_too() {
        // a grid with a wavy rim: fixed, the rim keeps its waves; free, they flatten
        let mut grid = synth::grid(12, 12, 1.0);
        let topo = Topology::new(&grid);
        let rim = topo.boundary_vertices();
        for (i, &v) in rim.iter().enumerate() {
            grid.positions[v as usize].z = if i % 2 == 0 { 0.05 } else { -0.05 };
        }
        let wave = |p: &[Point3<f64>]| rim.iter().map(|&v| p[v as usize].z.abs()).sum::<f64>();
        let fixed = taubin_with(&grid, &topo, 10, true);
        let free = taubin_with(&grid, &topo, 10, false);
        assert_eq!(fixed, taubin(&grid, &topo, 10));
        assert_eq!(wave(&fixed), wave(&grid.positions));
        assert!(wave(&free) < 0.5 * wave(&grid.positions));
    }

    #[test]
    fn boundary_vertices_stay() {
        let grid = synth::grid(6, 6, 1.0);
        let topo = Topology::new(&grid);
        let out = taubin(&grid, &topo, 5);
        for v in topo.boundary_vertices() {
            assert_eq!(out[v as usize], grid.positions[v as usize]);
        }
    }
}
