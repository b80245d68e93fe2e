//! The directed edges of a triangle mesh, grouped by the vertex they leave (compressed rows):
//! built in O(F) without hashing, an edge a→b found in O(valence of a). Half-edge i of face f
//! is edge `3·f + k`, from corner k to corner k + 1.

use keycomp_mesh::Mesh;

/// Directed edges by tail vertex (see the [module docs](self)).
#[derive(Debug, Clone)]
pub(crate) struct Directed {
    /// Row of vertex v: `start[v]..start[v + 1]`.
    start: Vec<u32>,
    /// Per entry: the head vertex and the edge id.
    entries: Vec<(u32, u32)>,
}

impl Directed {
    /// The directed edges of `mesh`'s faces (vertex indices must be in range, as a read mesh's
    /// are).
    pub(crate) fn new(mesh: &Mesh) -> Directed {
        let mut start = vec![0u32; mesh.positions.len() + 1];
        for t in &mesh.faces {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for v in 1..start.len() {
            start[v] += start[v - 1];
        }
        let mut fill = start.clone();
        let mut entries = vec![(0, 0); 3 * mesh.faces.len()];
        for (f, t) in mesh.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                entries[fill[a as usize] as usize] = (b, (3 * f + k) as u32);
                fill[a as usize] += 1;
            }
        }
        Directed { start, entries }
    }

    /// The edges leaving `a`: (head, edge id), in face order.
    pub(crate) fn leaving(&self, a: u32) -> &[(u32, u32)] {
        &self.entries[self.start[a as usize] as usize..self.start[a as usize + 1] as usize]
    }

    /// The first edge a→b (in face order), if any.
    pub(crate) fn find(&self, a: u32, b: u32) -> Option<u32> {
        self.leaving(a).iter().find(|e| e.0 == b).map(|e| e.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    /// Every face's edges are found, the reverse of an inner edge is its neighbour's, and a
    /// boundary edge has no reverse.
    #[test]
    fn finds_every_edge_and_its_reverse() {
        let mesh = synth::grid(3, 3, 1.0);
        let d = Directed::new(&mesh);
        let mut boundary = 0;
        for (f, t) in mesh.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                assert_eq!(d.find(a, b), Some((3 * f + k) as u32));
                match d.find(b, a) {
                    Some(r) => assert!(mesh.faces[r as usize / 3].contains(&a)),
                    None => boundary += 1,
                }
            }
        }
        // a 3 × 3 grid of squares has 12 boundary edges
        assert_eq!(boundary, 12);
        assert!(d.find(0, 0).is_none());
    }
}
