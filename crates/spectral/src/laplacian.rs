//! The cotangent Laplace–Beltrami operator of a triangle mesh: the stiffness matrix `W` and the
//! lumped (barycentric) mass matrix `M`, so that the eigenproblem `W φ = λ M φ` is the
//! linear-finite-element discretisation of `−Δ φ = λ φ` on the piecewise-flat surface.
//!
//! Cotangent formula: U. Pinkall and K. Polthier, "Computing discrete minimal surfaces and their
//! conjugates", *Experimental Mathematics* 2(1):15–36, 1993; lumped masses and the discrete
//! operator's analysis: M. Meyer, M. Desbrun, P. Schröder and A. H. Barr, "Discrete
//! differential-geometry operators for triangulated 2-manifolds", in *Visualization and
//! Mathematics III*, Springer, pp. 35–57, 2003.
//!
//! # Steps
//!
//! 1. **Index** the vertices some face refers to: `0..n` in mesh order (the *system* indices).
//!    Unreferenced vertices are left out of the system (they have no area and no neighbours;
//!    the spectrum gives them eigenvector entries 0, hence HKS 0).
//! 2. **Per face** (corners `i, j, k`, `2A = |(p_j − p_i) × (p_k − p_i)|`): the cotangent of the
//!    angle at corner `i` is `cot_i = (p_j − p_i)·(p_k − p_i) / 2A`, and the edge `jk` opposite it
//!    gets weight `½ cot_i` (likewise for the other two corners). Summed over faces an interior
//!    edge gets `w_jk = ½ (cot α + cot β)`, a boundary edge the single term `½ cot α` (natural,
//!    i.e. Neumann, boundary conditions).
//! 3. **Assemble** `W_jk = −w_jk` for `j ≠ k` and `W_jj = Σ_k w_jk`, so `W 1 = 0`.
//!    The face's mass `A/3` goes to each of its corners: `M = diag(m)`, `Σ m = total area`.
//!
//! Obtuse triangles give negative cotangents and possibly negative edge weights; that is
//! correct and harmless, because `W` is the sum over faces of the 3×3 P1 stiffness matrices,
//! each positive semi-definite (the Dirichlet energy of the linear interpolant), so `W` is
//! symmetric positive semi-definite whatever the triangle shapes, with one null vector (the
//! constant) per connected piece. No cotangent is clamped: clamping one cotangent of a face can
//! make that face's matrix indefinite.
//!
//! **Degenerate-triangle guard.** A needle or cap triangle has `2A ≪ ℓ²` and cotangents near
//! ±∞. The denominator is replaced by `max(2A, ε ℓ_max²)` with `ε =`
//! [`DEGENERATE_RATIO`] `= 1e-8` (ℓ_max the face's longest edge), which scales the face's three
//! cotangents by the *same* factor `≤ 1`: the face's matrix stays positive semi-definite, its
//! entries stay below about `1/ε` (angles below about `10⁻⁸` rad are treated as `10⁻⁸`), and
//! well-shaped faces are untouched. Faces with all corners coincident (`ℓ_max = 0`) are skipped.
//! [`Laplacian::guarded_faces`] counts the faces the guard changed. A referenced vertex whose
//! faces all have zero area would get zero mass; masses are floored at [`MASS_FLOOR`] times
//! the mean mass so `M` stays positive definite (such a vertex gets a huge eigenvalue and does
//! not disturb the low spectrum).
//!
//! # Complexity
//!
//! O(|F| log |F|) time (sorting the `3|F|` edge contributions) and O(|V| + |E|) memory: `W`
//! has `n + 2|E|` non-zeros, about `7n` on a closed mesh.

use keycomp_mesh::{Mesh, VertexId};

use crate::error::{Result, SpectralError};

/// Guard for degenerate triangles: a face's doubled area is floored at this fraction of its
/// longest squared edge before dividing (see the module docs).
pub const DEGENERATE_RATIO: f64 = 1e-8;

/// Lumped masses are floored at this fraction of the mean vertex mass (see the module docs).
pub const MASS_FLOOR: f64 = 1e-12;

/// The cotangent stiffness matrix `W` and lumped mass matrix `M` of a mesh, over the vertices
/// some face refers to. Build once with [`Laplacian::new`]; [`crate::Spectrum::compute`] builds
/// one itself.
#[derive(Debug, Clone)]
pub struct Laplacian {
    /// Mesh vertex id → system index (`u32::MAX` for an unreferenced vertex).
    pub(crate) index: Vec<u32>,
    /// System index → mesh vertex id.
    pub(crate) vertices: Vec<VertexId>,
    /// CSR row offsets of `W` (system indices), `n + 1` entries.
    pub(crate) row_offsets: Vec<usize>,
    /// CSR column indices of `W`, sorted within each row, diagonal included.
    pub(crate) cols: Vec<u32>,
    /// CSR values of `W`.
    pub(crate) values: Vec<f64>,
    /// Lumped mass per system index.
    pub(crate) mass: Vec<f64>,
    area: f64,
    guarded_faces: usize,
}

impl Laplacian {
    /// Assembles `W` and `M` for `mesh`.
    ///
    /// Errors: a face index out of range, a non-finite coordinate, or no face of positive area.
    pub fn new(mesh: &Mesh) -> Result<Laplacian> {
        let nv = mesh.num_vertices();
        // 1. system indices
        let mut index = vec![u32::MAX; nv];
        for (fi, f) in mesh.faces.iter().enumerate() {
            for &v in f {
                if v as usize >= nv {
                    return Err(SpectralError::FaceOutOfRange {
                        face: fi,
                        vertex: v,
                        vertices: nv,
                    });
                }
                index[v as usize] = 0;
            }
        }
        let mut vertices = Vec::new();
        for (v, slot) in index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = vertices.len() as u32;
                vertices.push(v as VertexId);
            }
        }
        let n = vertices.len();

        // 2. per-face cotangent weights and masses
        let mut mass = vec![0.0; n];
        let mut area = 0.0;
        let mut guarded_faces = 0;
        let mut edges: Vec<(u32, u32, f64)> = Vec::with_capacity(3 * mesh.num_faces());
        for (fi, f) in mesh.faces.iter().enumerate() {
            let p = f.map(|v| mesh.positions[v as usize]);
            if p.iter()
                .any(|q| !(q.x.is_finite() && q.y.is_finite() && q.z.is_finite()))
            {
                return Err(SpectralError::NonFiniteGeometry { face: fi });
            }
            let s = f.map(|v| index[v as usize]);
            let e = [p[2] - p[1], p[0] - p[2], p[1] - p[0]]; // e[i] is opposite corner i
            let twice_area = e[2].cross(&(-e[1])).norm();
            let longest = e.iter().map(|x| x.norm_squared()).fold(0.0, f64::max);
            if longest == 0.0 {
                continue;
            }
            let floor = DEGENERATE_RATIO * longest;
            let denom = if twice_area < floor {
                guarded_faces += 1;
                floor
            } else {
                twice_area
            };
            for i in 0..3 {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                // angle at corner i between edges to j and k: vectors p_j − p_i = e[k],
                // p_k − p_i = −e[j]
                let cot = e[k].dot(&(-e[j])) / denom;
                let (a, b) = (s[j].min(s[k]), s[j].max(s[k]));
                edges.push((a, b, 0.5 * cot));
                mass[s[i] as usize] += twice_area / 6.0;
            }
            area += 0.5 * twice_area;
        }
        if area <= 0.0 || n == 0 {
            return Err(SpectralError::NoSurface);
        }
        let mass_floor = MASS_FLOOR * area / n as f64;
        for m in &mut mass {
            *m = m.max(mass_floor);
        }

        // 3. assemble symmetric CSR (both triangles and the diagonal)
        edges.sort_unstable_by_key(|&(a, b, _)| (a, b));
        let mut merged: Vec<(u32, u32, f64)> = Vec::with_capacity(edges.len() / 2 + 1);
        for (a, b, w) in edges {
            match merged.last_mut() {
                Some(last) if last.0 == a && last.1 == b => last.2 += w,
                _ => merged.push((a, b, w)),
            }
        }
        let mut diag = vec![0.0; n];
        let mut count = vec![1usize; n]; // diagonal
        for &(a, b, w) in &merged {
            diag[a as usize] += w;
            diag[b as usize] += w;
            count[a as usize] += 1;
            count[b as usize] += 1;
        }
        let mut row_offsets = vec![0usize; n + 1];
        for i in 0..n {
            row_offsets[i + 1] = row_offsets[i] + count[i];
        }
        let nnz = row_offsets[n];
        let mut cols = vec![0u32; nnz];
        let mut values = vec![0.0; nnz];
        let mut fill = row_offsets.clone();
        let mut put = |r: usize, c: u32, v: f64, fill: &mut Vec<usize>| {
            cols[fill[r]] = c;
            values[fill[r]] = v;
            fill[r] += 1;
        };
        // merged is sorted by (a, b) with a < b: emitting, for each row r in increasing order,
        // the lower part (from pairs (c, r), c < r), then the diagonal, then the upper part
        // keeps every row sorted. Lower parts arrive in order of c because merged is sorted by a.
        let mut upper_start = vec![0usize; n + 1];
        for &(a, _, _) in &merged {
            upper_start[a as usize + 1] += 1;
        }
        for i in 0..n {
            upper_start[i + 1] += upper_start[i];
        }
        // lower entries: row b gets (a, w) for every pair (a, b); iterate pairs sorted by a
        for &(a, b, w) in &merged {
            put(b as usize, a, -w, &mut fill);
        }
        for r in 0..n {
            put(r, r as u32, diag[r], &mut fill);
            for &(_, b, w) in &merged[upper_start[r]..upper_start[r + 1]] {
                put(r, b, -w, &mut fill);
            }
        }
        Ok(Laplacian {
            index,
            vertices,
            row_offsets,
            cols,
            values,
            mass,
            area,
            guarded_faces,
        })
    }

    /// Number of vertices of the mesh (referenced or not).
    pub fn num_mesh_vertices(&self) -> usize {
        self.index.len()
    }

    /// Number of unknowns: the vertices some face refers to.
    pub fn system_size(&self) -> usize {
        self.vertices.len()
    }

    /// Number of non-zeros of `W` (both triangles and the diagonal).
    pub fn nonzeros(&self) -> usize {
        self.values.len()
    }

    /// Total surface area (sum of face areas), in mesh units squared.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// Number of faces whose cotangents the degenerate-triangle guard scaled down.
    pub fn guarded_faces(&self) -> usize {
        self.guarded_faces
    }

    /// The lumped mass of each mesh vertex (0 for an unreferenced vertex), in mesh units
    /// squared.
    pub fn masses(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.index.len()];
        for (s, &v) in self.vertices.iter().enumerate() {
            out[v as usize] = self.mass[s];
        }
        out
    }

    /// The edge weights `w_jk = ½ (cot α + cot β)` as `(j, k, w)` with mesh vertex ids `j < k`.
    pub fn edge_weights(&self) -> Vec<(VertexId, VertexId, f64)> {
        let mut out = Vec::with_capacity((self.values.len() - self.vertices.len()) / 2);
        for r in 0..self.vertices.len() {
            for e in self.row_offsets[r]..self.row_offsets[r + 1] {
                let c = self.cols[e] as usize;
                if c > r {
                    out.push((self.vertices[r], self.vertices[c], -self.values[e]));
                }
            }
        }
        out
    }

    /// `y = W x` for per-mesh-vertex vectors (entries of unreferenced vertices are ignored in
    /// `x` and 0 in `y`).
    ///
    /// Errors: `x` does not have one entry per mesh vertex.
    pub fn apply_stiffness(&self, x: &[f64]) -> Result<Vec<f64>> {
        if x.len() != self.index.len() {
            return Err(SpectralError::LengthMismatch {
                what: "x",
                found: x.len(),
                expected: self.index.len(),
            });
        }
        let xs: Vec<f64> = self.vertices.iter().map(|&v| x[v as usize]).collect();
        let mut ys = vec![0.0; xs.len()];
        self.stiffness_mul(&xs, &mut ys);
        let mut y = vec![0.0; self.index.len()];
        for (s, &v) in self.vertices.iter().enumerate() {
            y[v as usize] = ys[s];
        }
        Ok(y)
    }

    /// `y = W x` in system indices.
    pub(crate) fn stiffness_mul(&self, x: &[f64], y: &mut [f64]) {
        for (r, yr) in y.iter_mut().enumerate() {
            let mut acc = 0.0;
            for e in self.row_offsets[r]..self.row_offsets[r + 1] {
                acc += self.values[e] * x[self.cols[e] as usize];
            }
            *yr = acc;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::{Point3, synth};

    #[test]
    fn right_triangle_weights() {
        // right angle at corner 0: cot 90° = 0, cot 45° = 1 at the other two corners
        let m = Mesh {
            positions: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            faces: vec![[0, 1, 2]],
        };
        let l = Laplacian::new(&m).expect("valid");
        let w = l.edge_weights();
        let get = |a, b| w.iter().find(|e| e.0 == a && e.1 == b).map(|e| e.2);
        assert!(get(1, 2).expect("edge").abs() < 1e-15); // opposite the right angle
        assert!((get(0, 1).expect("edge") - 0.5).abs() < 1e-15);
        assert!((get(0, 2).expect("edge") - 0.5).abs() < 1e-15);
        assert!((l.area() - 0.5).abs() < 1e-15);
        for m in l.masses() {
            assert!((m - 0.5 / 3.0).abs() < 1e-15);
        }
    }

    #[test]
    fn rows_sum_to_zero_and_matrix_is_symmetric() {
        let m = synth::torus(2.0, 0.7, 24, 12);
        let l = Laplacian::new(&m).expect("valid");
        let n = l.system_size();
        for r in 0..n {
            let range = l.row_offsets[r]..l.row_offsets[r + 1];
            let s: f64 = l.values[range.clone()].iter().sum();
            assert!(s.abs() < 1e-12, "row {r} sums to {s}");
            assert!(l.cols[range.clone()].windows(2).all(|w| w[0] < w[1]));
            for e in range {
                let c = l.cols[e] as usize;
                let back = (l.row_offsets[c]..l.row_offsets[c + 1])
                    .find(|&f| l.cols[f] as usize == r)
                    .expect("symmetric pattern");
                assert_eq!(l.values[back], l.values[e]);
            }
        }
        assert_eq!(l.nonzeros(), n + 2 * l.edge_weights().len());
    }

    #[test]
    fn dirichlet_energy_of_a_linear_function_on_a_flat_grid() {
        // For u = a·x + b·y on a flat region, uᵀWu = |∇u|² · area (P1 elements are exact).
        let m = synth::grid(6, 5, 0.3);
        let l = Laplacian::new(&m).expect("valid");
        let u: Vec<f64> = m.positions.iter().map(|p| 2.0 * p.x - 0.5 * p.y).collect();
        let wu = l.apply_stiffness(&u).expect("length");
        let energy: f64 = u.iter().zip(&wu).map(|(a, b)| a * b).sum();
        let expected = (4.0 + 0.25) * l.area();
        assert!((energy - expected).abs() < 1e-10 * expected);
    }

    #[test]
    fn unreferenced_vertices_are_left_out() {
        let mut m = synth::icosphere(1, 1.0);
        m.positions.push(Point3::new(9.0, 9.0, 9.0));
        let l = Laplacian::new(&m).expect("valid");
        assert_eq!(l.system_size(), m.num_vertices() - 1);
        assert_eq!(*l.masses().last().expect("non-empty"), 0.0);
        let x = vec![1.0; m.num_vertices()];
        let y = l.apply_stiffness(&x).expect("length");
        assert!(y.iter().all(|v| v.abs() < 1e-12));
        assert!(l.apply_stiffness(&x[1..]).is_err());
    }

    #[test]
    fn needle_triangles_are_guarded_and_stay_finite() {
        let m = Mesh {
            positions: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.5, 1e-13, 0.0),
                Point3::new(0.5, 1.0, 0.0),
            ],
            faces: vec![[0, 1, 2], [0, 2, 3], [2, 1, 3]],
        };
        let l = Laplacian::new(&m).expect("valid");
        assert_eq!(l.guarded_faces(), 1);
        assert!(l.values.iter().all(|v| v.is_finite() && v.abs() < 1e9));
    }

    #[test]
    fn errors_have_context() {
        let bad = Mesh {
            positions: vec![Point3::new(0.0, 0.0, 0.0); 3],
            faces: vec![[0, 1, 5]],
        };
        assert!(matches!(
            Laplacian::new(&bad),
            Err(SpectralError::FaceOutOfRange {
                face: 0,
                vertex: 5,
                ..
            })
        ));
        let flat = Mesh {
            positions: vec![Point3::new(0.0, 0.0, 0.0); 3],
            faces: vec![[0, 1, 2]],
        };
        assert!(matches!(
            Laplacian::new(&flat),
            Err(SpectralError::NoSurface)
        ));
    }
}
