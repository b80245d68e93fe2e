//! Fragments for partial queries, cut from a shape: a geodesic ball, a plane cut and a simulated
//! single-view range scan, each keeping a requested fraction of the surface area.
//!
//! Every generator orders the faces by a key and keeps the shortest prefix whose area reaches
//! the target fraction (faces are kept whole, never split), so the kept area exceeds the target
//! by less than one face:
//!
//! * [`PartialKind::Ball`]: the key is the largest geodesic distance (fast marching,
//!   [`keycomp_geodesic::GeodesicSolver`]) of the face's corners from a centre vertex drawn by
//!   area (a random face, then a random corner): a geodesic ball. Faces the front cannot reach
//!   (another connected piece) are never kept, so on a shape in several pieces the ball can stop
//!   short of the target.
//! * [`PartialKind::Plane`]: the key is the signed distance of the face centroid along a
//!   uniformly random direction; the cut is [`keycomp_mesh::cut::cut_by_plane`] with the plane
//!   half way between the last kept centroid and the next.
//! * [`PartialKind::Scan`]: an orthographic range scanner looking along a uniformly random
//!   direction. A face is *seen* when it is nearest to the scanner at one sample of a
//!   [`SCAN_RESOLUTION`]² depth buffer (z-buffer with per-sample face ids) or, for a face too
//!   small to cover a sample centre, when its centroid is no deeper than the buffer there (plus
//!   a small tolerance), and it is not seen edge-on (`|n·d| ≥` [`GRAZING_COS`], like a scanner
//!   that gets no return at grazing angles). Among the seen faces, the key is the distance in
//!   the image plane from the seen area's centroid: a circular window of the scan. When the
//!   whole visible surface is smaller than the target (a view sees roughly half a closed
//!   shape), every seen face is kept and the fragment is smaller than asked: the achieved
//!   fraction is always reported.
//!
//! The direction and centre come from the caller's random stream, so a seeded stream gives the
//! same fragment every time.

use std::fmt;
use std::str::FromStr;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use keycomp_geodesic::GeodesicSolver;
use keycomp_mesh::{Mesh, Point3, Topology, Vector3, VertexId, cut, geometry};

/// Samples per side of the depth buffer of [`PartialKind::Scan`].
pub const SCAN_RESOLUTION: usize = 512;

/// Faces whose normal makes a cosine below this with the view direction are not seen by the
/// simulated scanner (about 84°).
pub const GRAZING_COS: f64 = 0.1;

/// How a partial query is cut from a shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PartialKind {
    /// A geodesic ball around a random point.
    Ball,
    /// The part of the shape on one side of a random plane.
    Plane,
    /// What a range scanner sees from one random direction.
    Scan,
}

impl PartialKind {
    /// All kinds, in order.
    pub const ALL: [PartialKind; 3] = [PartialKind::Ball, PartialKind::Plane, PartialKind::Scan];

    /// Lower-case name (`ball`, `plane`, `scan`).
    pub fn name(self) -> &'static str {
        match self {
            PartialKind::Ball => "ball",
            PartialKind::Plane => "plane",
            PartialKind::Scan => "scan",
        }
    }
}

impl fmt::Display for PartialKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for PartialKind {
    type Err = String;
    fn from_str(s: &str) -> Result<PartialKind, String> {
        PartialKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown partial query kind '{s}': use ball, plane or scan"))
    }
}

/// A fragment cut from a shape.
#[derive(Debug, Clone)]
pub struct Fragment {
    /// The kept faces, vertices renumbered ([`cut::submesh`]).
    pub mesh: Mesh,
    /// Original vertex id of each fragment vertex.
    pub original: Vec<VertexId>,
    /// Area of the fragment divided by the area of the shape.
    pub fraction: f64,
    /// What was drawn: the ball's centre vertex, the plane's normal or the view direction.
    pub detail: String,
}

/// Why a fragment cannot be cut.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PartialError {
    /// The shape has no area.
    #[error("the shape has zero surface area: nothing to cut")]
    ZeroArea,
    /// The target fraction is not in (0, 1].
    #[error("the area fraction {0} is not in (0, 1]")]
    BadFraction(f64),
    /// Fast marching failed (a malformed mesh).
    #[error("geodesic ball: {0}")]
    Geodesic(String),
    /// Nothing was kept (for example no face is seen by the scanner).
    #[error("the {0} fragment is empty")]
    Empty(PartialKind),
}

/// An orthonormal basis (u, w) of the image plane of a view along the unit vector `d`.
fn image_basis(d: Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if d.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = d.cross(&helper).normalize();
    (u, d.cross(&u))
}

/// A uniformly random unit vector.
fn random_direction(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vector3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The first faces of `order` (face ids) whose area reaches `target` (absolute area).
fn prefix_by_area(order: &[usize], areas: &[f64], target: f64) -> usize {
    let mut acc = 0.0;
    for (i, &f) in order.iter().enumerate() {
        acc += areas[f];
        if acc >= target {
            return i + 1;
        }
    }
    order.len()
}

fn centroid(mesh: &Mesh, f: usize) -> Point3<f64> {
    let [a, b, c] = mesh.triangle(f);
    Point3::from((a.coords + b.coords + c.coords) / 3.0)
}

/// Cuts a fragment of `kind` keeping about `fraction` of the area of `mesh`, drawing its centre
/// or direction from `rng` (see the [module docs](self)).
///
/// Errors: [`PartialError::BadFraction`], [`PartialError::ZeroArea`],
/// [`PartialError::Geodesic`], [`PartialError::Empty`].
pub fn cut_fragment(
    mesh: &Mesh,
    kind: PartialKind,
    fraction: f64,
    rng: &mut ChaCha8Rng,
) -> Result<Fragment, PartialError> {
    if !(fraction > 0.0 && fraction <= 1.0) {
        return Err(PartialError::BadFraction(fraction));
    }
    let areas = geometry::face_areas(mesh);
    let total: f64 = areas.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return Err(PartialError::ZeroArea);
    }
    let target = fraction * total;
    let (keep, detail): (Vec<bool>, String) = match kind {
        PartialKind::Ball => ball(mesh, &areas, total, target, rng)?,
        PartialKind::Plane => {
            let n = random_direction(rng);
            let key: Vec<f64> = (0..mesh.num_faces())
                .map(|f| centroid(mesh, f).coords.dot(&n))
                .collect();
            let mut order: Vec<usize> = (0..mesh.num_faces()).collect();
            // highest first: the positive side of the plane is kept
            order.sort_by(|&a, &b| key[b].total_cmp(&key[a]).then(a.cmp(&b)));
            let k = prefix_by_area(&order, &areas, target);
            let last = key[order[k - 1]];
            let offset = order.get(k).map_or(last - 1.0, |&f| 0.5 * (last + key[f]));
            let (m, orig) = cut::cut_by_plane(mesh, Point3::from(n * offset), n);
            let fr = geometry::total_area(&m) / total;
            let detail = format!("normal [{:.4}, {:.4}, {:.4}]", n.x, n.y, n.z);
            if m.num_faces() == 0 {
                return Err(PartialError::Empty(kind));
            }
            return Ok(Fragment {
                mesh: m,
                original: orig,
                fraction: fr,
                detail,
            });
        }
        PartialKind::Scan => scan(mesh, &areas, target, rng),
    };
    let (m, orig) = cut::submesh(mesh, |f| keep[f]);
    if m.num_faces() == 0 {
        return Err(PartialError::Empty(kind));
    }
    let fr = geometry::total_area(&m) / total;
    Ok(Fragment {
        mesh: m,
        original: orig,
        fraction: fr,
        detail,
    })
}

fn ball(
    mesh: &Mesh,
    areas: &[f64],
    total: f64,
    target: f64,
    rng: &mut ChaCha8Rng,
) -> Result<(Vec<bool>, String), PartialError> {
    // centre: a face drawn by area, then one of its corners
    let u = rng.random::<f64>() * total;
    let mut acc = 0.0;
    let mut face = mesh.num_faces() - 1;
    for (f, a) in areas.iter().enumerate() {
        acc += a;
        if acc > u {
            face = f;
            break;
        }
    }
    let centre = mesh.faces[face][rng.random_range(0..3)];
    let topo = Topology::new(mesh);
    let solver =
        GeodesicSolver::new(mesh, &topo).map_err(|e| PartialError::Geodesic(e.to_string()))?;
    let mut ws = solver.workspace();
    solver
        .solve(centre, &mut ws)
        .map_err(|e| PartialError::Geodesic(e.to_string()))?;
    let key: Vec<f64> = mesh
        .faces
        .iter()
        .map(|f| f.iter().map(|&v| ws.distance(v)).fold(0.0, f64::max))
        .collect();
    let mut order: Vec<usize> = (0..mesh.num_faces())
        .filter(|&f| key[f].is_finite())
        .collect();
    order.sort_by(|&a, &b| key[a].total_cmp(&key[b]).then(a.cmp(&b)));
    let k = prefix_by_area(&order, areas, target);
    let mut keep = vec![false; mesh.num_faces()];
    for &f in &order[..k] {
        keep[f] = true;
    }
    Ok((keep, format!("centre vertex {centre}")))
}

/// Faces seen by an orthographic scanner looking along `d`.
pub fn visible_faces(mesh: &Mesh, d: Vector3<f64>) -> Vec<bool> {
    let n_faces = mesh.num_faces();
    let d = d.normalize();
    let (u, w) = image_basis(d);
    let proj: Vec<[f64; 3]> = mesh
        .positions
        .iter()
        .map(|p| [p.coords.dot(&u), p.coords.dot(&w), p.coords.dot(&d)])
        .collect();
    let used: Vec<VertexId> = {
        let mut seen = vec![false; mesh.num_vertices()];
        for f in &mesh.faces {
            for &v in f {
                seen[v as usize] = true;
            }
        }
        (0..mesh.num_vertices() as u32)
            .filter(|&v| seen[v as usize])
            .collect()
    };
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let (mut zlo, mut zhi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in &used {
        let p = proj[v as usize];
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
        zlo = zlo.min(p[2]);
        zhi = zhi.max(p[2]);
    }
    let res = SCAN_RESOLUTION;
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-300);
    let cell = extent / (res - 1) as f64;
    let to_grid = |p: [f64; 3]| [(p[0] - lo[0]) / cell, (p[1] - lo[1]) / cell, p[2]];
    let mut depth = vec![f64::INFINITY; res * res];
    let mut owner = vec![u32::MAX; res * res];
    let normal_ok: Vec<bool> = (0..n_faces)
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            len > 0.0 && (n.dot(&d) / len).abs() >= GRAZING_COS
        })
        .collect();
    for (f, face) in mesh.faces.iter().enumerate() {
        let [a, b, c] = face.map(|v| to_grid(proj[v as usize]));
        let det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if det.abs() < 1e-18 {
            continue;
        }
        let x0 = a[0].min(b[0]).min(c[0]).ceil().max(0.0) as usize;
        let x1 = (a[0].max(b[0]).max(c[0]).floor() as usize).min(res - 1);
        let y0 = a[1].min(b[1]).min(c[1]).ceil().max(0.0) as usize;
        let y1 = (a[1].max(b[1]).max(c[1]).floor() as usize).min(res - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (px, py) = (x as f64, y as f64);
                let l1 = ((b[0] - px) * (c[1] - py) - (c[0] - px) * (b[1] - py)) / det;
                let l2 = ((c[0] - px) * (a[1] - py) - (a[0] - px) * (c[1] - py)) / det;
                let l3 = 1.0 - l1 - l2;
                if l1 < 0.0 || l2 < 0.0 || l3 < 0.0 {
                    continue;
                }
                let z = l1 * a[2] + l2 * b[2] + l3 * c[2];
                let i = y * res + x;
                if z < depth[i] || (z == depth[i] && (f as u32) < owner[i]) {
                    depth[i] = z;
                    owner[i] = f as u32;
                }
            }
        }
    }
    let mut seen = vec![false; n_faces];
    for &o in &owner {
        if o != u32::MAX {
            seen[o as usize] = true;
        }
    }
    // faces too small to own a sample: compare their centroid with the buffer around it
    let tol = 1e-3 * (zhi - zlo).max(extent);
    for (f, s) in seen.iter_mut().enumerate() {
        if *s {
            continue;
        }
        let g = to_grid({
            let c = centroid(mesh, f);
            [c.coords.dot(&u), c.coords.dot(&w), c.coords.dot(&d)]
        });
        let (x, y) = (g[0].round() as usize, g[1].round() as usize);
        if x < res && y < res {
            let z = depth[y * res + x];
            if z.is_infinite() || g[2] <= z + tol {
                *s = true;
            }
        }
    }
    for (s, ok) in seen.iter_mut().zip(&normal_ok) {
        *s &= ok;
    }
    seen
}

fn scan(mesh: &Mesh, areas: &[f64], target: f64, rng: &mut ChaCha8Rng) -> (Vec<bool>, String) {
    let d = random_direction(rng);
    let seen = visible_faces(mesh, d);
    let (u, w) = image_basis(d);
    let faces: Vec<usize> = (0..mesh.num_faces()).filter(|&f| seen[f]).collect();
    let centres: Vec<(f64, f64)> = (0..mesh.num_faces())
        .map(|f| {
            let c = centroid(mesh, f).coords;
            (c.dot(&u), c.dot(&w))
        })
        .collect();
    let seen_area: f64 = faces.iter().map(|&f| areas[f]).sum();
    let (mut cx, mut cy) = (0.0, 0.0);
    for &f in &faces {
        cx += areas[f] * centres[f].0;
        cy += areas[f] * centres[f].1;
    }
    if seen_area > 0.0 {
        cx /= seen_area;
        cy /= seen_area;
    }
    let key = |f: usize| (centres[f].0 - cx).powi(2) + (centres[f].1 - cy).powi(2);
    let mut order = faces;
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    let k = prefix_by_area(&order, areas, target);
    let mut keep = vec![false; mesh.num_faces()];
    for &f in &order[..k] {
        keep[f] = true;
    }
    (keep, format!("view [{:.4}, {:.4}, {:.4}]", d.x, d.y, d.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;
    use rand::SeedableRng;

    fn rng(seed: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(seed)
    }

    #[test]
    fn every_kind_keeps_the_requested_area() {
        let m = synth::icosphere(4, 1.0);
        for kind in PartialKind::ALL {
            for (seed, target) in [(1, 0.2), (2, 0.35), (3, 0.45)] {
                let f = cut_fragment(&m, kind, target, &mut rng(seed)).unwrap();
                // a face of an icosphere(4) is about 1/5120 of the area
                assert!(
                    f.fraction >= target - 1e-9 && f.fraction < target + 0.01,
                    "{kind} {target}: {}",
                    f.fraction
                );
                assert_eq!(f.original.len(), f.mesh.num_vertices());
                for (i, &o) in f.original.iter().enumerate() {
                    assert_eq!(f.mesh.positions[i], m.positions[o as usize]);
                }
            }
        }
    }

    #[test]
    fn deterministic_for_a_seed() {
        let m = synth::protrusion_sphere(3, 0.5, 0.4);
        for kind in PartialKind::ALL {
            let a = cut_fragment(&m, kind, 0.3, &mut rng(5)).unwrap();
            let b = cut_fragment(&m, kind, 0.3, &mut rng(5)).unwrap();
            assert_eq!(a.mesh, b.mesh);
            assert_eq!(a.detail, b.detail);
            let c = cut_fragment(&m, kind, 0.3, &mut rng(6)).unwrap();
            assert_ne!(a.mesh, c.mesh, "{kind}");
        }
    }

    #[test]
    fn a_ball_is_geodesically_compact_and_a_plane_cut_is_a_half_space() {
        let m = synth::icosphere(4, 1.0);
        let f = cut_fragment(&m, PartialKind::Ball, 0.25, &mut rng(3)).unwrap();
        // a geodesic ball of a sphere is a spherical cap: every vertex lies within the cap's
        // angular radius (area fraction a = (1 − cos θ)/2) plus one edge
        let centre: usize = f
            .detail
            .trim_start_matches("centre vertex ")
            .parse()
            .unwrap();
        let c = m.positions[centre].coords.normalize();
        let cos_theta = 1.0 - 2.0 * 0.25;
        for p in &f.mesh.positions {
            assert!(p.coords.normalize().dot(&c) > cos_theta - 0.05);
        }
        let g = cut_fragment(&m, PartialKind::Plane, 0.25, &mut rng(3)).unwrap();
        // a plane cutting 25 % of a sphere's area is at height 1 − 2·0.25 = 0.5 along its normal
        let n: Vec<f64> = g
            .detail
            .trim_start_matches("normal [")
            .trim_end_matches(']')
            .split(", ")
            .map(|x| x.parse().unwrap())
            .collect();
        let n = Vector3::new(n[0], n[1], n[2]);
        for p in &g.mesh.positions {
            assert!(p.coords.dot(&n) > 0.5 - 0.05);
        }
    }

    #[test]
    fn a_scan_sees_about_half_a_sphere_and_never_its_back() {
        let m = synth::icosphere(4, 1.0);
        let d = Vector3::new(0.3, -0.5, 0.8).normalize();
        let seen = visible_faces(&m, d);
        let areas = geometry::face_areas(&m);
        let total: f64 = areas.iter().sum();
        let seen_area: f64 = (0..m.num_faces())
            .filter(|&f| seen[f])
            .map(|f| areas[f])
            .sum();
        // the front hemisphere minus the grazing band |cos| < 0.1 (area fraction 0.05)
        let frac = seen_area / total;
        assert!((frac - 0.45).abs() < 0.02, "{frac}");
        for (f, &s) in seen.iter().enumerate() {
            if s {
                assert!(centroid(&m, f).coords.dot(&d) < 0.0, "a back face is seen");
            }
        }
        // asking for more than is visible keeps every seen face
        let frag = cut_fragment(&m, PartialKind::Scan, 0.9, &mut rng(1)).unwrap();
        assert!(frag.fraction < 0.5, "{}", frag.fraction);
    }

    #[test]
    fn an_occluded_face_is_not_seen() {
        // two parallel squares, one behind the other along z
        let mut grid = synth::grid(10, 10, 0.1);
        let n = grid.positions.len() as u32;
        let back: Vec<Point3<f64>> = grid
            .positions
            .iter()
            .map(|p| Point3::new(p.x, p.y, p.z + 1.0))
            .collect();
        let back_faces: Vec<[u32; 3]> = grid.faces.iter().map(|f| f.map(|v| v + n)).collect();
        let front_count = grid.faces.len();
        grid.positions.extend(back);
        grid.faces.extend(back_faces);
        let seen = visible_faces(&grid, Vector3::z());
        assert!(seen[..front_count].iter().all(|&s| s));
        assert!(seen[front_count..].iter().all(|&s| !s));
    }

    #[test]
    fn bad_arguments() {
        let m = synth::icosphere(1, 1.0);
        assert_eq!(
            cut_fragment(&m, PartialKind::Ball, 0.0, &mut rng(0)).unwrap_err(),
            PartialError::BadFraction(0.0)
        );
        assert!("cube".parse::<PartialKind>().is_err());
        assert_eq!("scan".parse::<PartialKind>(), Ok(PartialKind::Scan));
    }
}
