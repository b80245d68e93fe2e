//! Repeatability measured through the canonical surface: detection runs on the canonical
//! surface of each shape ([`keycomp_surface::canonical`], the surface `--surface canonical`
//! analyses), and its components are carried back to the shape's own vertices, where the
//! experiment's ground truth lives ([`crate::evaluate`]).
//!
//! **Carrying back.** Every vertex of the shape is labelled with the canonical vertex nearest
//! to it in space (a KD-tree; the canonical surface lies on the shape's triangles, so the
//! nearest canonical vertex is within about one grid spacing). A canonical component C becomes
//! the shape's vertices labelled with a member of C: the union of C's Voronoi cells restricted
//! to the shape's vertices. Components that repeat on the canonical surfaces of a shape and its
//! transformation therefore repeat on the shapes, up to a band of half a cell along their
//! boundaries, and the overlap is measured exactly as for detection on the shapes themselves.
//!
//! Cost: O(|V| log |V_c|) to label, O(k) per carried component of k canonical vertices plus
//! the size of its cells.

use keycomp_mesh::{Mesh, VertexId};

/// The shape's vertices grouped by their nearest canonical vertex, in CSR form.
#[derive(Debug, Clone)]
pub struct Carrier {
    offsets: Vec<u32>,
    cells: Vec<VertexId>,
}

impl Carrier {
    /// Labels every vertex of `mesh` with its nearest vertex of `canonical` (a canonical
    /// surface without vertices labels nothing).
    pub fn new(mesh: &Mesh, canonical: &Mesh) -> Self {
        let n_c = canonical.num_vertices();
        let mut counts = vec![0u32; n_c + 1];
        // no canonical vertex: no labels, every cell empty
        let labels = keycomp_surface::trim::nearest_vertices(&mesh.positions, &canonical.positions)
            .unwrap_or_default();
        for &c in &labels {
            counts[c as usize + 1] += 1;
        }
        for i in 0..n_c {
            counts[i + 1] += counts[i];
        }
        let mut next = counts.clone();
        let mut cells = vec![0; labels.len()];
        for (v, &c) in labels.iter().enumerate() {
            cells[next[c as usize] as usize] = v as VertexId;
            next[c as usize] += 1;
        }
        Carrier {
            offsets: counts,
            cells,
        }
    }

    /// The shape's vertices whose nearest canonical vertex is in `component` (canonical vertex
    /// ids; ids out of range are ignored), sorted.
    pub fn carry(&self, component: &[VertexId]) -> Vec<VertexId> {
        let mut out: Vec<VertexId> = component
            .iter()
            .filter(|&&c| (c as usize) + 1 < self.offsets.len())
            .flat_map(|&c| {
                let (a, b) = (self.offsets[c as usize], self.offsets[c as usize + 1]);
                self.cells[a as usize..b as usize].iter().copied()
            })
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::Point3;

    fn points(p: &[[f64; 3]]) -> Mesh {
        Mesh {
            positions: p.iter().map(|&[x, y, z]| Point3::new(x, y, z)).collect(),
            faces: Vec::new(),
        }
    }

    #[test]
    fn each_vertex_goes_with_its_nearest_canonical_vertex() {
        // oracle: brute-force nearest neighbour
        let shape: Vec<[f64; 3]> = (0..50)
            .map(|i| {
                let t = i as f64 * 0.37;
                [t.sin(), t.cos(), 0.1 * t]
            })
            .collect();
        let canon: Vec<[f64; 3]> = (0..7)
            .map(|i| {
                let t = i as f64 * 2.6;
                [t.sin(), t.cos(), 0.1 * t]
            })
            .collect();
        let carrier = Carrier::new(&points(&shape), &points(&canon));
        let nearest = |p: &[f64; 3]| {
            (0..canon.len())
                .min_by(|&a, &b| {
                    let d = |c: &[f64; 3]| (0..3).map(|k| (c[k] - p[k]).powi(2)).sum::<f64>();
                    d(&canon[a]).total_cmp(&d(&canon[b]))
                })
                .unwrap() as VertexId
        };
        let component = [1, 4, 5];
        let expected: Vec<VertexId> = (0..shape.len() as VertexId)
            .filter(|&v| component.contains(&nearest(&shape[v as usize])))
            .collect();
        assert!(!expected.is_empty());
        assert_eq!(carrier.carry(&component), expected);
        // every vertex lies in exactly one cell
        let all: Vec<VertexId> = (0..canon.len() as VertexId).collect();
        assert_eq!(carrier.carry(&all).len(), shape.len());
        assert!(carrier.carry(&[99]).is_empty());
    }

    #[test]
    fn the_same_vertices_carry_onto_themselves() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 3.0],
        ];
        let carrier = Carrier::new(&points(&p), &points(&p));
        assert_eq!(carrier.carry(&[2, 0]), vec![0, 2]);
    }
}
