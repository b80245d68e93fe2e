//! Consistent face orientation per connected piece, so that sample normals say which side of
//! a sheet is its front ([`crate::trim`]).
//!
//! 1. Pieces are the classes of faces joined across *manifold* edges (edges with exactly two
//!    faces); a breadth-first walk flips each newly reached face so that it runs the shared
//!    edge in the opposite direction to its neighbour, as two faces of one oriented surface do.
//! 2. A *closed* piece (every edge of its faces manifold) is turned outward: its signed volume
//!    `Σ det(a − o, b − o, c − o) / 6` (divergence theorem, o the piece's first vertex) must be
//!    positive.
//! 3. An open piece keeps the winding most of its area has in the file (a scan or a fragment is
//!    wound as its source was).
//!
//! Cost: O(F log F) (sorting the edges).

use keycomp_mesh::{Mesh, geometry};

/// Per face, `true` when its winding must be reversed.
pub fn orient_faces(mesh: &Mesh) -> Vec<bool> {
    let nf = mesh.faces.len();
    // (low, high, face, runs low -> high)
    let mut edges: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * nf);
    for (f, t) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if a != b {
                edges.push((a.min(b), a.max(b), f as u32, a < b));
            }
        }
    }
    edges.sort_unstable();
    // per face: its manifold neighbours (neighbour, same direction on the shared edge)
    let mut adjacency: Vec<Vec<(u32, bool)>> = vec![Vec::new(); nf];
    let mut open = vec![false; nf];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
            j += 1;
        }
        if j - i == 2 {
            let (f, g) = (edges[i].2, edges[i + 1].2);
            let same = edges[i].3 == edges[i + 1].3;
            if f != g {
                adjacency[f as usize].push((g, same));
                adjacency[g as usize].push((f, same));
            }
        } else {
            for e in &edges[i..j] {
                open[e.2 as usize] = true;
            }
        }
        i = j;
    }
    let areas = geometry::face_areas(mesh);
    let mut flip = vec![false; nf];
    let mut seen = vec![false; nf];
    let mut piece = Vec::new();
    let mut queue = std::collections::VecDeque::new();
    for start in 0..nf {
        if seen[start] {
            continue;
        }
        piece.clear();
        seen[start] = true;
        queue.push_back(start as u32);
        while let Some(f) = queue.pop_front() {
            piece.push(f);
            for &(g, same) in &adjacency[f as usize] {
                if !seen[g as usize] {
                    seen[g as usize] = true;
                    // same direction on the shared edge: one of the two must turn
                    flip[g as usize] = flip[f as usize] ^ same;
                    queue.push_back(g);
                }
            }
        }
        let closed = piece.iter().all(|&f| !open[f as usize]);
        let reverse = if closed {
            signed_volume(mesh, &piece, &flip) < 0.0
        } else {
            let (mut kept, mut turned) = (0.0, 0.0);
            for &f in &piece {
                if flip[f as usize] {
                    turned += areas[f as usize];
                } else {
                    kept += areas[f as usize];
                }
            }
            turned > kept
        };
        if reverse {
            for &f in &piece {
                flip[f as usize] = !flip[f as usize];
            }
        }
    }
    flip
}

/// Signed volume enclosed by the faces of `piece`, each wound as `flip` says.
fn signed_volume(mesh: &Mesh, piece: &[u32], flip: &[bool]) -> f64 {
    let Some(&first) = piece.first() else {
        return 0.0;
    };
    let o = mesh.positions[mesh.faces[first as usize][0] as usize];
    piece
        .iter()
        .map(|&f| {
            let [a, b, c] = mesh.triangle(f as usize);
            let v = (a - o).dot(&(b - o).cross(&(c - o))) / 6.0;
            if flip[f as usize] { -v } else { v }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    /// A closed mesh wound outward is left alone; wound inward it is reversed; with half its
    /// faces reversed it comes back consistent and outward.
    #[test]
    fn closed_pieces_face_outward() {
        let mut m = synth::icosphere(2, 1.0);
        assert!(orient_faces(&m).iter().all(|&f| !f));
        for t in &mut m.faces {
            t.swap(1, 2);
        }
        assert!(orient_faces(&m).iter().all(|&f| f));
        let mut mixed = synth::icosphere(2, 1.0);
        for t in mixed.faces.iter_mut().step_by(2) {
            t.swap(1, 2);
        }
        let flip = orient_faces(&mixed);
        for (k, &f) in flip.iter().enumerate() {
            assert_eq!(f, k % 2 == 0, "face {k}");
        }
    }

    /// An open sheet keeps the winding most of its area has.
    #[test]
    fn open_pieces_keep_the_majority_winding() {
        let mut m = synth::grid(6, 6, 1.0);
        let n = m.faces.len();
        for t in m.faces.iter_mut().take(n / 4) {
            t.swap(1, 2);
        }
        let flip = orient_faces(&m);
        assert_eq!(flip.iter().filter(|&&f| f).count(), n / 4);
        assert!(flip.iter().take(n / 4).all(|&f| f));
    }
}
