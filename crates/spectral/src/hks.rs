//! The heat kernel signature and its keypoints.
//!
//! J. Sun, M. Ovsjanikov and L. Guibas, "A concise and provably informative multi-scale
//! signature based on heat diffusion", *Computer Graphics Forum* 28(5):1383–1392 (Proc.
//! Symposium on Geometry Processing, SGP), 2009.
//!
//! The heat kernel `k_t(x, y) = Σ_i exp(−λ_i t) φ_i(x) φ_i(y)` is the amount of heat at `y`
//! after time `t` from a unit heat source at `x`; its diagonal, the **heat kernel signature**
//! `HKS_t(x) = k_t(x, x) = Σ_i exp(−λ_i t) φ_i(x)²`, is large where heat stays — at tips of
//! protrusions, whose neighbourhood offers little room to diffuse into. Small `t` sees local
//! geometry (`HKS_t(x) ≈ 1/(4πt) + K(x)/(12π) + O(t)`, K the Gaussian curvature), large `t`
//! the global shape; as `t → ∞` it tends to `1/area`.
//!
//! # Keypoints (Sipiran & Bustos 2013, Section 4.4)
//!
//! I. Sipiran and B. Bustos, "Key-components: detection of salient regions on 3D meshes", *The
//! Visual Computer* 29(12), 2013, compare against HKS keypoints computed at
//! `t = 0.1 × surface area` ([`paper_time`]): a vertex `x` is a keypoint if
//! `HKS_t(x) > HKS_t(y)` for every `y` in its 2-ring ([`hks_keypoints`]).
//!
//! **Units.** `λ` is in length⁻², so `t` is in length², and `t = 0.1 × area` is the choice that
//! makes the signature scale-free: scaling the mesh by `s` multiplies `λ` by `s⁻²`, `φ` by `s⁻¹`
//! (M-normalisation) and the area by `s²`, so `λ t` is unchanged and `HKS` is multiplied by
//! `s⁻²` — the keypoints do not move. The paper's meshes have area 1, so its `t` is 0.1
//! there. This is a *large* time: heat has spread over a disc of area about `4πt ≈ 1.3 ×` the
//! whole surface. On a sphere of area A, `λ_1 = 8π/A`, so `exp(−λ_1 t) = exp(−0.8π) ≈ 0.08` and
//! `exp(−λ_2 t) ≈ 5·10⁻⁴`: the signature is dominated by the first few eigenfunctions and its
//! maxima are the shape's extremities. The truncation error of `k` eigenpairs is below
//! `exp(−λ_k t) · Σ_{i≥k} φ_i(x)² e^{−(λ_i−λ_k)t}`, negligible for `k ≥ 20` at this `t`; smaller
//! `t` (finer features) needs more eigenpairs. On `synth::protrusion_sphere(5, 0.8, 0.25)` the
//! paper's `t` gives exactly six keypoints, one within two rings of each protrusion tip; at
//! `t = 0.01 × area` every tip vertex itself is a keypoint (plus three on the body).
//!
//! # Complexity
//!
//! `HKS_t`: O(n k). Keypoints: O(n d²) with d the vertex degree (one 2-ring per vertex).

use keycomp_mesh::{Mesh, Topology, VertexId};

use crate::error::{Result, SpectralError};
use crate::spectrum::Spectrum;

/// The diffusion time of Sipiran & Bustos (2013, Section 4.4): `t = 0.1 × area`, in mesh units
/// squared.
pub fn paper_time(area: f64) -> f64 {
    0.1 * area
}

impl Spectrum {
    /// The heat kernel signature at time `t` (mesh units squared):
    /// `HKS_t(x) = Σ_i exp(−λ_i t) φ_i(x)²` for every mesh vertex, in mesh units⁻²
    /// (0 at unreferenced vertices).
    pub fn hks(&self, t: f64) -> Vec<f64> {
        let n = self.num_vertices();
        let mut out = vec![0.0; n];
        for (i, &lambda) in self.eigenvalues().iter().enumerate() {
            let w = (-lambda * t).exp();
            if w == 0.0 {
                break; // eigenvalues ascend, so every later weight is 0 too
            }
            for (o, &p) in out.iter_mut().zip(self.eigenvector(i)) {
                *o += w * p * p;
            }
        }
        out
    }

    /// The heat kernel `k_t(x, y) = Σ_i exp(−λ_i t) φ_i(x) φ_i(y)` between two mesh vertices.
    ///
    /// Errors: a vertex id out of range.
    pub fn heat_kernel(&self, t: f64, x: VertexId, y: VertexId) -> Result<f64> {
        let n = self.num_vertices();
        for v in [x, y] {
            if v as usize >= n {
                return Err(SpectralError::LengthMismatch {
                    what: "vertex id",
                    found: v as usize,
                    expected: n,
                });
            }
        }
        Ok(self
            .eigenvalues()
            .iter()
            .enumerate()
            .map(|(i, &l)| {
                let phi = self.eigenvector(i);
                (-l * t).exp() * phi[x as usize] * phi[y as usize]
            })
            .sum())
    }
}

/// The HKS keypoints of Sipiran & Bustos (2013, Section 4.4): every vertex whose value in `hks`
/// is strictly greater than the value at every other vertex of its 2-ring
/// ([`Topology::rings`]), in increasing id order. Vertices without neighbours (unreferenced)
/// and NaN values are never keypoints; ties are not maxima.
///
/// Errors: `hks` or `topo` does not have one entry per mesh vertex.
pub fn hks_keypoints(mesh: &Mesh, topo: &Topology, hks: &[f64]) -> Result<Vec<VertexId>> {
    let n = mesh.num_vertices();
    if hks.len() != n {
        return Err(SpectralError::LengthMismatch {
            what: "hks",
            found: hks.len(),
            expected: n,
        });
    }
    if topo.num_vertices() != n {
        return Err(SpectralError::LengthMismatch {
            what: "topology",
            found: topo.num_vertices(),
            expected: n,
        });
    }
    let mut mark = vec![false; n];
    let mut ring = Vec::new();
    let mut out = Vec::new();
    for v in 0..n as VertexId {
        let h = hks[v as usize];
        if topo.neighbors(v).is_empty() || h.is_nan() {
            continue;
        }
        // cheap rejection on the 1-ring first
        if topo.neighbors(v).iter().any(|&w| hks[w as usize] >= h) {
            continue;
        }
        topo.rings(v, 2, &mut mark, &mut ring);
        if ring[1..].iter().all(|&w| h > hks[w as usize]) {
            out.push(v);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::SpectrumParams;
    use keycomp_mesh::{Point3, synth};

    #[test]
    fn sphere_hks_matches_the_analytic_series() {
        // On a sphere of radius r, HKS_t = Σ_l (2l+1)/(4πr²) exp(−l(l+1)t/r²) at every point.
        let r = 1.5;
        let mesh = synth::icosphere(4, r);
        let s = Spectrum::compute(
            &mesh,
            &SpectrumParams {
                count: 64,
                ..Default::default()
            },
        )
        .expect("converges");
        let t = 0.1 * r * r;
        let exact: f64 = (0..60)
            .map(|l| {
                let l = l as f64;
                (2.0 * l + 1.0) / (4.0 * std::f64::consts::PI * r * r)
                    * (-l * (l + 1.0) * t / (r * r)).exp()
            })
            .sum();
        for h in s.hks(t) {
            assert!((h - exact).abs() < 0.01 * exact, "{h} vs {exact}");
        }
        // t → ∞: only the constant mode φ0 = 1/√area remains
        for h in s.hks(1e3 * s.area()) {
            assert!((h * s.area() - 1.0).abs() < 1e-8);
        }
    }

    #[test]
    fn hks_is_scale_covariant_and_keypoints_scale_invariant() {
        let mesh = synth::protrusion_sphere(3, 0.8, 0.35);
        let scale = 3.0;
        let big = Mesh {
            positions: mesh.positions.iter().map(|p| p * scale).collect(),
            faces: mesh.faces.clone(),
        };
        let params = SpectrumParams {
            count: 60,
            ..Default::default()
        };
        let a = Spectrum::compute(&mesh, &params).expect("converges");
        let b = Spectrum::compute(&big, &params).expect("converges");
        assert!((b.area() / a.area() - scale * scale).abs() < 1e-9);
        let ha = a.hks(paper_time(a.area()));
        let hb = b.hks(paper_time(b.area()));
        for (x, y) in ha.iter().zip(&hb) {
            assert!((y * scale * scale - x).abs() < 1e-7 * x, "{x} vs {y}");
        }
        let topo = Topology::new(&mesh);
        assert_eq!(
            hks_keypoints(&mesh, &topo, &ha).expect("lengths"),
            hks_keypoints(&big, &topo, &hb).expect("lengths")
        );
    }

    #[test]
    fn protrusion_tips_are_hks_keypoints() {
        let mesh = synth::protrusion_sphere(5, 0.8, 0.25);
        let topo = Topology::new(&mesh);
        let s = Spectrum::compute(
            &mesh,
            &SpectrumParams {
                count: 100,
                ..Default::default()
            },
        )
        .expect("converges");
        let tips = synth::protrusion_tips(&mesh);
        // the paper's time: one keypoint at each protrusion, within two rings of its tip
        let kp = hks_keypoints(&mesh, &topo, &s.hks(paper_time(s.area()))).expect("lengths");
        assert_eq!(kp.len(), tips.len(), "{kp:?}");
        let (mut mark, mut ring) = (vec![false; mesh.num_vertices()], Vec::new());
        for &t in &tips {
            topo.rings(t, 2, &mut mark, &mut ring);
            assert!(
                ring.iter().any(|v| kp.contains(v)),
                "no keypoint near tip {t}"
            );
        }
        // a moderate time: every tip vertex itself is a keypoint
        let kp = hks_keypoints(&mesh, &topo, &s.hks(0.01 * s.area())).expect("lengths");
        for t in &tips {
            assert!(kp.contains(t), "tip {t} is not a keypoint: {kp:?}");
        }
    }

    #[test]
    fn keypoints_are_strict_two_ring_maxima() {
        let mesh = synth::grid(8, 8, 1.0);
        let topo = Topology::new(&mesh);
        let n = mesh.num_vertices();
        // a peak at vertex 40 (column 4, row 4) and a plateau of equal values elsewhere
        let mut h = vec![0.0; n];
        h[40] = 2.0;
        h[10] = 1.0;
        h[11] = 1.0; // tie with a neighbour: neither is a keypoint
        assert_eq!(hks_keypoints(&mesh, &topo, &h).expect("lengths"), vec![40]);
        // a vertex in the 2-ring but not the 1-ring beats it
        h[42] = 3.0;
        assert_eq!(hks_keypoints(&mesh, &topo, &h).expect("lengths"), vec![42]);
        h[40] = f64::NAN;
        assert!(
            !hks_keypoints(&mesh, &topo, &h)
                .expect("lengths")
                .contains(&40)
        );
        assert!(matches!(
            hks_keypoints(&mesh, &topo, &h[1..]),
            Err(SpectralError::LengthMismatch { what: "hks", .. })
        ));
        // an unreferenced vertex is never a keypoint
        let mut m2 = mesh.clone();
        m2.positions.push(Point3::new(50.0, 0.0, 0.0));
        let t2 = Topology::new(&m2);
        let mut h2 = vec![0.0; n + 1];
        h2[n] = 10.0;
        assert!(hks_keypoints(&m2, &t2, &h2).expect("lengths").is_empty());
    }

    #[test]
    fn heat_kernel_diagonal_is_the_hks() {
        let mesh = synth::icosphere(3, 1.0);
        let s = Spectrum::compute(
            &mesh,
            &SpectrumParams {
                count: 40,
                ..Default::default()
            },
        )
        .expect("converges");
        let h = s.hks(0.2);
        let k = s.heat_kernel(0.2, 7, 7).expect("in range");
        assert!((h[7] - k).abs() < 1e-12);
        let k01 = s.heat_kernel(0.2, 0, 1).expect("in range");
        let k10 = s.heat_kernel(0.2, 1, 0).expect("in range");
        assert!((k01 - k10).abs() < 1e-15);
        assert!(s.heat_kernel(0.2, 0, 1_000_000).is_err());
    }
}
