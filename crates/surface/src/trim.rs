//! One side of open sheets, and no specks.
//!
//! Around a closed solid the offset surface is one outer skin. Around an open sheet (a scan,
//! a fragment, a panel modelled as one polygon) the outside reaches both sides and the skin
//! has a back. For each face, with x its centroid and p, n the nearest sample and its normal:
//! the point y = p + 2(p − x), as deep past the input as twice the offset, is looked up; if y is
//! outside, the face belongs to a two-sided sheet and is kept only when `(x − p)·n ≥ 0`, the
//! side the input faces. Elsewhere (y inside a solid) every face is kept: a closed solid loses
//! nothing, whatever its orientation. Samples without a normal keep both sides.
//!
//! Then the pieces of the result with less than a share of its area are dropped, and the
//! vertices no face uses.
//!
//! Cost: O(F log S) for F faces and S samples (one nearest-sample query per face).

use keycomp_mesh::{Mesh, Point3, Topology, Vector3, geometry};
use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use rayon::prelude::*;

use crate::error::SurfaceError;
use crate::sample::Samples;
use crate::volume::Volume;

/// A KD-tree over points (their indices as items).
pub(crate) type Tree = ImmutableKdTree<f64, u32, 3, 32>;

/// The KD-tree of `points`.
pub(crate) fn kd_tree(points: &[Point3<f64>]) -> Tree {
    let coords: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
    ImmutableKdTree::new_from_slice(&coords)
}

/// For each of `points`, the index of the nearest of `to` (in parallel; `None` when `to` is
/// empty). Carries what is computed on a canonical surface (per vertex) back to the input's
/// vertices or points, which the surface lies on.
pub fn nearest_vertices(points: &[Point3<f64>], to: &[Point3<f64>]) -> Option<Vec<u32>> {
    if to.is_empty() {
        return None;
    }
    let tree = kd_tree(to);
    Some(
        points
            .par_iter()
            .map(|p| tree.nearest_one::<SquaredEuclidean>(&[p.x, p.y, p.z]).item)
            .collect(),
    )
}

/// The indices of the `k` points of `tree` nearest `x`, nearest first (fewer when the tree
/// has fewer points).
pub(crate) fn nearest_ids(tree: &Tree, x: &Point3<f64>, k: usize) -> Vec<u32> {
    match std::num::NonZero::new(k.min(tree.size())) {
        Some(k) => tree
            .nearest_n::<SquaredEuclidean>(&[x.x, x.y, x.z], k)
            .into_iter()
            .map(|nb| nb.item)
            .collect(),
        None => Vec::new(),
    }
}

/// Nearest-sample queries over the samples.
pub struct Nearest<'a> {
    samples: &'a Samples,
    tree: Tree,
}

impl<'a> Nearest<'a> {
    /// The search structure of `samples`.
    pub fn new(samples: &'a Samples) -> Self {
        Nearest {
            samples,
            tree: kd_tree(&samples.positions),
        }
    }

    /// The sample nearest `x` and its normal (none without samples).
    pub fn sample(&self, x: &Point3<f64>) -> Option<(Point3<f64>, Vector3<f64>)> {
        if self.samples.positions.is_empty() {
            return None;
        }
        let i = self
            .tree
            .nearest_one::<SquaredEuclidean>(&[x.x, x.y, x.z])
            .item as usize;
        Some((self.samples.positions[i], self.samples.normals[i]))
    }

    /// The `k` samples nearest `x`, nearest first.
    fn nearest_k(&self, x: &Point3<f64>, k: usize) -> Vec<u32> {
        nearest_ids(&self.tree, x, k)
    }
}

/// Samples whose faces are tried when projecting a vertex onto a mesh ([`project`]).
pub const PROJECTION_CANDIDATES: usize = 6;

/// Faces kept by [`one_sided`] and how many were removed.
#[derive(Debug, Clone, PartialEq)]
pub struct Trimmed {
    /// The faces kept, in their order.
    pub faces: Vec<[u32; 3]>,
    /// Per kept face, whether it lies on a two-sided sheet (its front).
    pub sheet: Vec<bool>,
    /// Faces removed as the back of an open sheet.
    pub removed: usize,
}

fn centroid(positions: &[Point3<f64>], t: &[u32; 3]) -> Point3<f64> {
    Point3::from(
        (positions[t[0] as usize].coords
            + positions[t[1] as usize].coords
            + positions[t[2] as usize].coords)
            / 3.0,
    )
}

/// The faces of the offset surface (`positions`, `faces`) of `vol` that are not the back of an
/// open sheet (see the module docs).
pub fn one_sided(
    vol: &Volume,
    nearest: &Nearest,
    positions: &[Point3<f64>],
    faces: &[[u32; 3]],
) -> Trimmed {
    // per face: (kept, on a sheet)
    let verdict: Vec<(bool, bool)> = faces
        .par_iter()
        .map(|t| {
            let x = centroid(positions, t);
            let Some((p, n)) = nearest.sample(&x) else {
                return (true, false);
            };
            if n.norm_squared() == 0.0 {
                return (true, false);
            }
            let y = p + (p - x) * 2.0;
            let two_sided = vol.nearest_node(&y).is_none_or(|m| vol.outside[m]);
            (!two_sided || (x - p).dot(&n) >= 0.0, two_sided)
        })
        .collect();
    let before = faces.len();
    let (mut kept, mut sheet) = (Vec::with_capacity(before), Vec::with_capacity(before));
    for (&f, (k, s)) in faces.iter().zip(verdict) {
        if k {
            kept.push(f);
            sheet.push(s);
        }
    }
    Trimmed {
        removed: before - kept.len(),
        faces: kept,
        sheet,
    }
}

/// Moves each vertex of the offset surface back onto the input, undoing the offset r and
/// keeping the connectivity the volume gave (pieces of a soup joined, hidden faces gone, one
/// side of open sheets): onto the nearest point of the input faces of its
/// [`PROJECTION_CANDIDATES`] nearest samples (exact, so sharp edges stay straight), or, for a
/// point cloud, onto the tangent plane of its nearest sample, `x ← x − ((x − p)·n) n`. A vertex
/// moves at most `2r` (a bridge the offset threw across a gap stays a bridge). Vertices of
/// faces that the projection flattens into slivers (three corners on one sharp edge of the
/// input) are moved back halfway, up to [`SLIVER_PASSES`] times, then to where they were, so
/// that no face of the result degenerates.
pub fn project(
    positions: &mut [Point3<f64>],
    faces: &[[u32; 3]],
    nearest: &Nearest,
    mesh: Option<&Mesh>,
    r: f64,
) {
    let before = positions.to_vec();
    project_all(positions, nearest, mesh, r);
    for pass in 0..=SLIVER_PASSES {
        let mut bad = vec![false; positions.len()];
        let mut any = false;
        for t in faces {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            let twice_area = (b - a).cross(&(c - a)).norm();
            let longest = (b - a)
                .norm_squared()
                .max((c - b).norm_squared())
                .max((a - c).norm_squared());
            if twice_area.partial_cmp(&(SLIVER * longest)) != Some(std::cmp::Ordering::Greater) {
                for &v in t {
                    bad[v as usize] = true;
                }
                any = true;
            }
        }
        if !any {
            return;
        }
        for (v, x) in positions.iter_mut().enumerate() {
            if bad[v] {
                *x = if pass == SLIVER_PASSES {
                    before[v]
                } else {
                    Point3::from((x.coords + before[v].coords) * 0.5)
                };
            }
        }
    }
}

/// A projected face is a sliver when twice its area is at most this fraction of its longest
/// squared edge (its smallest height is under a millionth of its longest edge).
const SLIVER: f64 = 1e-6;

/// Halfway moves back tried on slivers before their vertices return to the offset surface.
pub const SLIVER_PASSES: usize = 3;

fn project_all(positions: &mut [Point3<f64>], nearest: &Nearest, mesh: Option<&Mesh>, r: f64) {
    let samples = nearest.samples;
    positions.par_iter_mut().for_each(|x| {
        let near = nearest.nearest_k(x, PROJECTION_CANDIDATES);
        let Some(&first) = near.first() else {
            return;
        };
        let target = match mesh {
            Some(mesh) => near
                .iter()
                .filter_map(|&i| {
                    let f = samples.faces[i as usize] as usize;
                    (f < mesh.faces.len()).then(|| closest_on_triangle(x, &mesh.triangle(f)))
                })
                .min_by(|a, b| {
                    (*a - *x)
                        .norm_squared()
                        .total_cmp(&(*b - *x).norm_squared())
                }),
            None => {
                let (p, n) = (
                    samples.positions[first as usize],
                    samples.normals[first as usize],
                );
                (n.norm_squared() > 0.0).then(|| *x - n * (*x - p).dot(&n))
            }
        };
        if let Some(t) = target {
            let d = t - *x;
            let len = d.norm();
            *x += if len > 2.0 * r {
                d * (2.0 * r / len)
            } else {
                d
            };
        }
    });
}

/// The point of triangle `t` nearest `p` (C. Ericson, *Real-Time Collision Detection*, 2005,
/// §5.1.5: by the Voronoi region of `p`).
pub fn closest_on_triangle(p: &Point3<f64>, t: &[Point3<f64>; 3]) -> Point3<f64> {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        return a;
    }
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

/// Of the faces of a sheet (once projected), those whose centroid lies farther than `r / 2`
/// from every sample are left out: the skin the offset wrapped around an open boundary, which
/// projection lays flat beyond the input's edge. Faces of closed solids are kept whatever
/// their distance (bridges across a soup's cracks join its pieces). Returns the faces kept and
/// how many were left out.
pub fn drop_overhang(
    positions: &[Point3<f64>],
    nearest: &Nearest,
    trimmed: Trimmed,
    r: f64,
) -> (Vec<[u32; 3]>, usize) {
    let limit = (0.5 * r) * (0.5 * r);
    let keep: Vec<bool> = trimmed
        .faces
        .par_iter()
        .zip(&trimmed.sheet)
        .map(|(t, &sheet)| {
            !sheet || {
                let x = centroid(positions, t);
                nearest
                    .sample(&x)
                    .is_none_or(|(p, _)| (x - p).norm_squared() <= limit)
            }
        })
        .collect();
    let before = trimmed.faces.len();
    let faces: Vec<[u32; 3]> = trimmed
        .faces
        .into_iter()
        .zip(keep)
        .filter_map(|(f, k)| k.then_some(f))
        .collect();
    let dropped = before - faces.len();
    (faces, dropped)
}

/// The mesh of `faces` over `positions` without its pieces under `min_piece` of the area and
/// without unused vertices; also the number of faces dropped with small pieces. Errors with
/// [`SurfaceError::Empty`] when nothing is left.
pub fn drop_small_pieces(
    positions: Vec<Point3<f64>>,
    faces: Vec<[u32; 3]>,
    min_piece: f64,
) -> Result<(Mesh, usize), SurfaceError> {
    let mesh = compact(positions, faces)?;
    let large = LargePieces::of(&mesh, min_piece);
    let dropped = mesh.faces.len() - large.faces.len();
    Ok((compact(mesh.positions, large.faces)?, dropped))
}

/// The faces of a mesh's pieces of at least a share of its area ([`LargePieces::of`]).
pub(crate) struct LargePieces {
    /// The kept faces, in the mesh's order.
    pub faces: Vec<[u32; 3]>,
    /// Each vertex's piece (`Topology::connected_components`).
    pub label: Vec<u32>,
    /// How many pieces the kept faces make.
    pub pieces: usize,
}

impl LargePieces {
    /// The faces of `mesh` in pieces of at least `min_piece` of its area.
    pub fn of(mesh: &Mesh, min_piece: f64) -> LargePieces {
        let (label, pieces) = Topology::new(mesh).connected_components();
        let areas = geometry::face_areas(mesh);
        let mut piece_area = vec![0.0; pieces];
        for (f, t) in mesh.faces.iter().enumerate() {
            piece_area[label[t[0] as usize] as usize] += areas[f];
        }
        let total: f64 = piece_area.iter().sum();
        let large = |l: u32| piece_area[l as usize] >= min_piece * total;
        let faces: Vec<[u32; 3]> = mesh
            .faces
            .iter()
            .copied()
            .filter(|t| large(label[t[0] as usize]))
            .collect();
        let mut seen = vec![false; pieces];
        for t in &faces {
            seen[label[t[0] as usize] as usize] = true;
        }
        let pieces = seen.iter().filter(|&&s| s).count();
        LargePieces {
            faces,
            label,
            pieces,
        }
    }
}

/// A validated mesh of `faces` (degenerate ones dropped) over the vertices they use, in order
/// of first use.
fn compact(positions: Vec<Point3<f64>>, faces: Vec<[u32; 3]>) -> Result<Mesh, SurfaceError> {
    if faces.is_empty() {
        return Err(SurfaceError::Empty);
    }
    let (mesh, _) = Mesh::from_raw(positions, faces).map_err(|_| SurfaceError::Empty)?;
    let mut map = vec![u32::MAX; mesh.positions.len()];
    let mut kept = Vec::new();
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .map(|t| {
            t.map(|v| {
                let slot = &mut map[v as usize];
                if *slot == u32::MAX {
                    *slot = kept.len() as u32;
                    kept.push(mesh.positions[v as usize]);
                }
                *slot
            })
        })
        .collect();
    Ok(Mesh {
        positions: kept,
        faces,
    })
}
