//! Adjacency of a triangle mesh in compressed (CSR) form: vertex → neighbouring vertices,
//! vertex → incident faces, plus edge-incidence counts for boundary detection.
//!
//! Built once in O(|F| log d) (d = largest vertex degree) and shared by every algorithm that walks
//! the mesh (Harris rings, fast marching, region growing).

use rayon::prelude::*;

use crate::{Mesh, VertexId};

/// Vertex–vertex and vertex–face adjacency of a [`Mesh`].
///
/// Neighbour lists are sorted by vertex id and contain each neighbour once, however many faces
/// share the edge (non-manifold edges are fine).
#[derive(Debug, Clone)]
pub struct Topology {
    vv_offsets: Vec<u32>,
    vv: Vec<VertexId>,
    /// Number of faces on each edge `vv[k]`, parallel to `vv`.
    vv_faces: Vec<u32>,
    vf_offsets: Vec<u32>,
    vf: Vec<u32>,
}

impl Topology {
    /// Builds the adjacency of `mesh`.
    pub fn new(mesh: &Mesh) -> Topology {
        let n = mesh.num_vertices();
        // vertex -> faces
        let mut vf_offsets = vec![0u32; n + 1];
        for f in &mesh.faces {
            for &v in f {
                vf_offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            vf_offsets[i + 1] += vf_offsets[i];
        }
        let mut fill = vf_offsets.clone();
        let mut vf = vec![0u32; vf_offsets[n] as usize];
        for (fi, f) in mesh.faces.iter().enumerate() {
            for &v in f {
                let slot = &mut fill[v as usize];
                vf[*slot as usize] = fi as u32;
                *slot += 1;
            }
        }
        // vertex -> vertices: each face gives every corner its two other corners; sort and
        // count duplicates (the count is the number of faces on that edge). Vertices in
        // parallel, in pieces of `CHUNK` joined in order, so the result is the same as one pass.
        const CHUNK: usize = 4096;
        let pieces: Vec<(Vec<VertexId>, Vec<u32>, Vec<u32>)> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let (lo, hi) = (c * CHUNK, ((c + 1) * CHUNK).min(n));
                let mut vv = Vec::with_capacity(7 * (hi - lo));
                let mut faces = Vec::with_capacity(7 * (hi - lo));
                let mut ends = Vec::with_capacity(hi - lo);
                let mut scratch: Vec<VertexId> = Vec::new();
                for v in lo..hi {
                    scratch.clear();
                    for &fi in &vf[vf_offsets[v] as usize..vf_offsets[v + 1] as usize] {
                        for &w in &mesh.faces[fi as usize] {
                            if w as usize != v {
                                scratch.push(w);
                            }
                        }
                    }
                    scratch.sort_unstable();
                    let mut i = 0;
                    while i < scratch.len() {
                        let w = scratch[i];
                        let mut j = i;
                        while j < scratch.len() && scratch[j] == w {
                            j += 1;
                        }
                        vv.push(w);
                        faces.push((j - i) as u32);
                        i = j;
                    }
                    ends.push(vv.len() as u32);
                }
                (vv, faces, ends)
            })
            .collect();
        let total: usize = pieces.iter().map(|p| p.0.len()).sum();
        let mut vv_offsets = Vec::with_capacity(n + 1);
        vv_offsets.push(0u32);
        let mut vv = Vec::with_capacity(total);
        let mut vv_faces = Vec::with_capacity(total);
        for (piece_vv, piece_faces, ends) in pieces {
            let base = vv.len() as u32;
            vv_offsets.extend(ends.iter().map(|e| base + e));
            vv.extend(piece_vv);
            vv_faces.extend(piece_faces);
        }
        Topology {
            vv_offsets,
            vv,
            vv_faces,
            vf_offsets,
            vf,
        }
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.vv_offsets.len() - 1
    }

    /// The vertices sharing an edge with `v`, sorted by id.
    #[inline]
    pub fn neighbors(&self, v: VertexId) -> &[VertexId] {
        let v = v as usize;
        &self.vv[self.vv_offsets[v] as usize..self.vv_offsets[v + 1] as usize]
    }

    /// The faces having `v` as a corner, in increasing face order.
    #[inline]
    pub fn faces_of(&self, v: VertexId) -> &[u32] {
        let v = v as usize;
        &self.vf[self.vf_offsets[v] as usize..self.vf_offsets[v + 1] as usize]
    }

    /// The faces having a corner among `vertices`, sorted and without repeats.
    pub fn faces_touching(&self, vertices: &[VertexId]) -> Vec<u32> {
        let mut faces: Vec<u32> = vertices
            .iter()
            .flat_map(|&v| self.faces_of(v).iter().copied())
            .collect();
        faces.sort_unstable();
        faces.dedup();
        faces
    }

    /// Number of faces on the edge from `v` to each of its neighbours, parallel to
    /// [`Topology::neighbors`]: 1 on a boundary edge, 2 on a manifold interior edge, more on a
    /// non-manifold edge.
    #[inline]
    pub fn edge_face_counts(&self, v: VertexId) -> &[u32] {
        let v = v as usize;
        &self.vv_faces[self.vv_offsets[v] as usize..self.vv_offsets[v + 1] as usize]
    }

    /// Whether `v` lies on an open boundary (has an edge with exactly one incident face).
    pub fn is_boundary(&self, v: VertexId) -> bool {
        self.edge_face_counts(v).contains(&1)
    }

    /// All boundary vertices, in increasing id order.
    pub fn boundary_vertices(&self) -> Vec<VertexId> {
        (0..self.num_vertices() as VertexId)
            .filter(|&v| self.is_boundary(v))
            .collect()
    }

    /// Connected components of the vertex graph: a label per vertex (labels 0.. in order of each
    /// piece's smallest vertex id) and the number of pieces. An unreferenced vertex is a piece
    /// of its own.
    pub fn connected_components(&self) -> (Vec<u32>, usize) {
        let n = self.num_vertices();
        let mut label = vec![u32::MAX; n];
        let mut count = 0u32;
        let mut stack = Vec::new();
        for s in 0..n {
            if label[s] != u32::MAX {
                continue;
            }
            label[s] = count;
            stack.push(s as VertexId);
            while let Some(v) = stack.pop() {
                for &w in self.neighbors(v) {
                    if label[w as usize] == u32::MAX {
                        label[w as usize] = count;
                        stack.push(w);
                    }
                }
            }
            count += 1;
        }
        (label, count as usize)
    }

    /// Vertices within `rings` edge-hops of `v` (including `v`), in breadth-first order.
    /// `mark` must be all-false on entry, with one slot per vertex; it is all-false again on
    /// return, so one buffer serves many calls.
    pub fn rings(&self, v: VertexId, rings: usize, mark: &mut [bool], out: &mut Vec<VertexId>) {
        out.clear();
        out.push(v);
        mark[v as usize] = true;
        let mut start = 0;
        for _ in 0..rings {
            let end = out.len();
            if start == end {
                break;
            }
            for i in start..end {
                let u = out[i];
                for &w in self.neighbors(u) {
                    if !mark[w as usize] {
                        mark[w as usize] = true;
                        out.push(w);
                    }
                }
            }
            start = end;
        }
        for &u in out.iter() {
            mark[u as usize] = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Point3;

    fn two_triangles_and_a_loose_one() -> Mesh {
        let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
        Mesh {
            positions: vec![
                p(0.0, 0.0),
                p(1.0, 0.0),
                p(0.0, 1.0),
                p(1.0, 1.0),
                p(5.0, 5.0),
                p(6.0, 5.0),
                p(5.0, 6.0),
            ],
            faces: vec![[0, 1, 2], [1, 3, 2], [4, 5, 6]],
        }
    }

    #[test]
    fn adjacency_of_a_small_mesh() {
        let m = two_triangles_and_a_loose_one();
        let t = Topology::new(&m);
        assert_eq!(t.neighbors(0), &[1, 2]);
        assert_eq!(t.neighbors(1), &[0, 2, 3]);
        assert_eq!(t.edge_face_counts(1), &[1, 2, 1]);
        assert_eq!(t.faces_of(2), &[0, 1]);
        // every vertex of an open quad and a lone triangle is on the boundary
        assert_eq!(t.boundary_vertices(), vec![0, 1, 2, 3, 4, 5, 6]);
        let (labels, n) = t.connected_components();
        assert_eq!(n, 2);
        assert_eq!(labels, vec![0, 0, 0, 0, 1, 1, 1]);
    }

    #[test]
    fn rings_grow_breadth_first_and_reset_marks() {
        let m = two_triangles_and_a_loose_one();
        let t = Topology::new(&m);
        let mut mark = vec![false; m.num_vertices()];
        let mut out = Vec::new();
        t.rings(0, 1, &mut mark, &mut out);
        assert_eq!(out, vec![0, 1, 2]);
        t.rings(0, 2, &mut mark, &mut out);
        assert_eq!(out, vec![0, 1, 2, 3]);
        assert!(mark.iter().all(|m| !m));
    }
}
