//! Checking that a mesh is a closed, manifold, consistently oriented surface without
//! degenerate faces, and measuring it (Euler characteristic, pieces, signed volume, worst
//! triangle).

use std::collections::HashMap;

use keycomp_mesh::Mesh;

/// What [`check_closed_manifold`] measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceReport {
    /// Vertices.
    pub vertices: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Faces.
    pub faces: usize,
    /// Euler characteristic `V − E + F` (2 − 2·genus per closed piece).
    pub euler: i64,
    /// Connected pieces (through shared edges).
    pub components: usize,
    /// Signed enclosed volume (divergence theorem); positive when the faces turn outwards.
    pub signed_volume: f64,
    /// Smallest triangle corner angle, in degrees.
    pub min_angle_deg: f64,
    /// Smallest face area divided by the mean face area.
    pub min_relative_area: f64,
}

/// Checks that `mesh` is closed, edge- and vertex-manifold and consistently oriented: every
/// directed edge occurs in exactly one face and its reverse in exactly one other, every vertex
/// is used and its faces form a single fan closed around it, and no face has zero area. Returns
/// the measurements, or a message naming the first problem found.
pub fn check_closed_manifold(mesh: &Mesh) -> Result<SurfaceReport, String> {
    let nv = mesh.num_vertices();
    let mut directed: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * mesh.num_faces());
    for (fi, f) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            let e = (f[k], f[(k + 1) % 3]);
            if e.0 as usize >= nv || e.1 as usize >= nv || e.0 == e.1 {
                return Err(format!("face {fi} has a bad vertex index {f:?}"));
            }
            if directed.insert(e, fi as u32).is_some() {
                return Err(format!(
                    "edge {}→{} is used twice in the same direction (inconsistent orientation or non-manifold edge)",
                    e.0, e.1
                ));
            }
        }
    }
    for &(a, b) in directed.keys() {
        if !directed.contains_key(&(b, a)) {
            return Err(format!("edge {a}–{b} has one face only (open boundary)"));
        }
    }
    // Vertex manifoldness: around v, face (v, a, b) links a → b; the links must form one cycle.
    let mut next: Vec<Vec<(u32, u32)>> = vec![Vec::new(); nv];
    for f in &mesh.faces {
        for k in 0..3 {
            next[f[k] as usize].push((f[(k + 1) % 3], f[(k + 2) % 3]));
        }
    }
    for (v, links) in next.iter().enumerate() {
        if links.is_empty() {
            return Err(format!("vertex {v} is in no face"));
        }
        let map: HashMap<u32, u32> = links.iter().copied().collect();
        let start = links[0].0;
        let (mut cur, mut steps) = (start, 0);
        loop {
            match map.get(&cur) {
                Some(&n) => cur = n,
                None => return Err(format!("the faces around vertex {v} are not a closed fan")),
            }
            steps += 1;
            if cur == start || steps > links.len() {
                break;
            }
        }
        if steps != links.len() {
            return Err(format!(
                "vertex {v} is non-manifold: its faces form more than one fan"
            ));
        }
    }
    // Pieces, by union-find over faces sharing an edge.
    let mut parent: Vec<usize> = (0..mesh.num_faces()).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for (&(a, b), &f) in &directed {
        if let Some(&g) = directed.get(&(b, a)) {
            let (rf, rg) = (find(&mut parent, f as usize), find(&mut parent, g as usize));
            parent[rf.max(rg)] = rf.min(rg);
        }
    }
    let components = (0..mesh.num_faces())
        .filter(|&f| find(&mut parent, f) == f)
        .count();
    let mut volume = 0.0;
    let mut min_angle = f64::INFINITY;
    let mut areas = Vec::with_capacity(mesh.num_faces());
    for (fi, _) in mesh.faces.iter().enumerate() {
        let [a, b, c] = mesh.triangle(fi);
        volume += a.coords.dot(&b.coords.cross(&c.coords)) / 6.0;
        let area = 0.5 * (b - a).cross(&(c - a)).norm();
        if area.is_nan() || area <= 0.0 {
            return Err(format!("face {fi} has zero area"));
        }
        areas.push(area);
        for (p, q, r) in [(a, b, c), (b, c, a), (c, a, b)] {
            let cos = ((q - p).normalize()).dot(&(r - p).normalize());
            min_angle = min_angle.min(cos.clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    let mean = areas.iter().sum::<f64>() / areas.len().max(1) as f64;
    let min_area = areas.iter().copied().fold(f64::INFINITY, f64::min);
    let edges = directed.len() / 2;
    Ok(SurfaceReport {
        vertices: nv,
        edges,
        faces: mesh.num_faces(),
        euler: nv as i64 - edges as i64 + mesh.num_faces() as i64,
        components,
        signed_volume: volume,
        min_angle_deg: min_angle,
        min_relative_area: min_area / mean,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    #[test]
    fn icosphere_and_torus_pass_with_their_euler_characteristic() {
        let s = check_closed_manifold(&synth::icosphere(2, 1.0)).expect("sphere");
        assert_eq!((s.euler, s.components), (2, 1));
        assert!(s.signed_volume > 0.0);
        let t = check_closed_manifold(&synth::torus(1.0, 0.3, 24, 12)).expect("torus");
        assert_eq!(t.euler, 0);
    }

    #[test]
    fn defects_are_found() {
        let good = synth::icosphere(1, 1.0);
        let mut open = good.clone();
        open.faces.pop();
        assert!(
            check_closed_manifold(&open)
                .unwrap_err()
                .contains("one face")
        );
        let mut flipped = good.clone();
        let f = flipped.faces[0];
        flipped.faces[0] = [f[0], f[2], f[1]];
        assert!(
            check_closed_manifold(&flipped)
                .unwrap_err()
                .contains("same direction")
        );
        // Two spheres glued at one vertex: a non-manifold vertex.
        let mut pinched = good.clone();
        let n = pinched.positions.len() as u32;
        let other = synth::icosphere(1, 1.0);
        pinched.positions.extend(
            other
                .positions
                .iter()
                .map(|p| p + keycomp_mesh::Vector3::new(3.0, 0.0, 0.0)),
        );
        pinched.faces.extend(
            other
                .faces
                .iter()
                .map(|f| f.map(|v| if v == 0 { 0 } else { v + n })),
        );
        let e = check_closed_manifold(&pinched).unwrap_err();
        assert!(
            e.contains("non-manifold") || e.contains("in no face"),
            "{e}"
        );
        let mut inverted = good.clone();
        for f in &mut inverted.faces {
            *f = [f[0], f[2], f[1]];
        }
        assert!(
            check_closed_manifold(&inverted)
                .expect("valid")
                .signed_volume
                < 0.0
        );
    }
}
