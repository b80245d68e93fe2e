//! The canonical surface: what keycomp analyses instead of the file as it is.
//!
//! Detection and description follow the vertices they are given: Harris neighbourhoods,
//! keypoint budgets (1 % of the vertices), smoothing passes and part sizes all change with the
//! tessellation, and a triangle soup (a CAD model made of intersecting, separately modelled
//! pieces, with faces hidden inside the solid and inconsistent orientation) has no connected
//! surface for geodesics to run on. So every input — a mesh at any resolution, a soup, a range
//! scan, a bare point cloud — is first remade as an **isotropic remesh lying on its own
//! geometry**: nearly equilateral triangles of one edge length L, fixed per unit of the area
//! of the shape the input stands for ([`Density`]), whose vertices lie on the input. Two
//! copies of a shape with different triangles then become two samplings of the same density
//! of the same surface, and only that surface is analysed.
//!
//! **A clean mesh** — edge- and vertex-manifold, consistently oriented, its pieces apart from
//! each other (no two within L/4; pieces under [`SurfaceParams::min_piece`] of the area are
//! left out as specks) — is remeshed directly ([`remesh`]: splits, collapses, flips and
//! tangential relaxation after Botsch & Kobbelt 2004, every vertex projected onto the input's
//! faces, boundary vertices onto its boundary edges), after its holes shorter than
//! [`HOLE_PERIMETER`]·L around are closed (below the surface's resolution; a mesh's micro-holes
//! would otherwise make borders where the shape has none). The result keeps the input's
//! topology: no webs across gaps, no lost thin parts, real holes and borders kept.
//!
//! **Anything else** — a soup, a mesh whose pieces touch or cross, a range scan's triangulated
//! grid with specks, a bare point cloud — is reconstructed from an offset volume (steps 1–5
//! below), which joins the pieces into one surface and drops hidden faces, and that
//! reconstruction is analysed as it is made ([`Surface::reconstructed`]): its surface-nets
//! triangles are already close to equilateral and of one size, and its vertices already lie on
//! the input. It is not remeshed: projected onto the input, the two sides of a thin panel would
//! fall onto one another.
//!
//! L is chosen so that the result has about [`SurfaceParams::vertices`] vertices for a whole
//! shape: equilateral triangles of side L, two per vertex, cover an area A when
//! L² = 2A / (√3·N). The reconstruction:
//!
//! 1. **Oriented samples** ([`mod@sample`], [`normals`]). A mesh is sampled on a regular
//!    barycentric lattice of spacing h/2 on every face, each sample carrying its face's
//!    normal, after the faces of each connected piece have been oriented consistently (closed
//!    pieces outward); a point cloud is used as it is, thinned to one point per (h/2)³ cell,
//!    with its own normals or normals fitted by PCA to its nearest neighbours and oriented by
//!    propagation over the neighbour graph (H. Hoppe, T. DeRose, T. Duchamp, J. McDonald,
//!    W. Stuetzle, "Surface reconstruction from unorganized points", SIGGRAPH 1992).
//! 2. **Offset volume** ([`volume`]). On a grid of spacing h, the distance from each node to
//!    the nearest sample, in a narrow band; nodes nearer than the offset radius r (about h)
//!    are the *shell*. A flood fill from the grid's border through the other nodes marks the
//!    *outside*. Whatever the fill cannot reach — the shell and the space it encloses — is the
//!    solid: the union of every piece of a soup, whatever lies hidden inside it.
//! 3. **Surface nets** ([`nets`]): the boundary of the outside, one vertex per grid cell it
//!    crosses (at the mean of the crossings of the level `distance = r` on the cell's edges),
//!    one quad per grid edge it crosses, split along its shorter diagonal (S. F. Gibson,
//!    "Constrained elastic surface nets: generating smooth surfaces from binary segmented
//!    data", MICCAI 1998). The triangles are close to equilateral, the surface is closed
//!    and connected wherever the input is, and it lies r outside the input.
//! 4. **One side of open sheets** ([`trim`]). Around an open surface (a scan, a fragment, a
//!    single-sided panel) the outside reaches both sides, and the shell has a front and a back.
//!    Where the point mirrored through the input (twice as deep on the other side) is outside
//!    too, the face is kept only on the side its nearest sample's normal points to: a scan or a
//!    fragment keeps one side and its boundary, a closed solid keeps everything (its mirror
//!    points lie inside it). Only an input whose shell is at least [`SHEET_SHARE`] backs is
//!    trimmed: a solid's thin parts, or a CAD soup's single-sided panels, stay closed. Pieces
//!    of less than [`SurfaceParams::min_piece`] of the area (specks of sensor noise) are
//!    dropped.
//! 5. **Back onto the input** ([`trim::project`]). Each vertex moves to the nearest point of the
//!    input: of the mesh's triangles near it, or of the tangent plane of the nearest points of
//!    a cloud (where the skin wrapped around a cloud's open border lies flat beyond the last
//!    points, those faces are dropped). The surface keeps the nets' even sampling and
//!    connectivity, and the input's geometry instead of an offset r outside it.
//!
//! The reconstruction's grid spacing h is chosen so that it has about as many vertices as a
//! remesh would: from the input's area (a point cloud's from its point spacing), then once more
//! from the area of the surface made when the first estimate missed by more than 15 % (a
//! soup's hidden faces count in its area but not in its outer surface). The grid is bounded by
//! [`MAX_NODES`] nodes: an input whose extent is huge for its area gets a coarser spacing
//! instead of an unbounded allocation. Remeshing makes at most 16 times the target's vertex
//! count in faces beyond its start's ([`remesh::RemeshParams::max_faces`]).
//!
//! Cost: the remesh O(R·V·d) for [`REMESH_ROUNDS`] rounds over V vertices of degree d, plus a
//! nearest-point query per vertex and round ([`closest`], O(log F)); the reconstruction
//! O(S·(R/h)³) for S samples (about 8·A/h², so O(V) for a budget of V vertices), the flood fill
//! and the nets in O(grid nodes), the trimming in O(V log S). Everything is deterministic: no
//! random numbers, and parallel loops write disjoint slices.

pub mod closest;
mod directed;
mod error;
pub mod nets;
pub mod normals;
pub mod orient;
pub mod remesh;
pub mod sample;
pub mod trim;
pub mod volume;

pub use error::SurfaceError;
pub use trim::nearest_vertices;
pub use volume::MAX_NODES;

use keycomp_mesh::{Mesh, Point3, Vector3, geometry};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Surface-nets vertices per unit of area and squared spacing: a surface of area A on a grid
/// of spacing h gets about `NETS_DENSITY · A / h²` vertices (a plane crosses more cells than
/// its area in cell faces unless it is aligned with the grid; measured on spheres and the
/// test meshes).
pub const NETS_DENSITY: f64 = 1.55;

/// Share of the offset surface's faces that must be the back of a sheet for the input to be
/// taken as open (a scan, a fragment: about half of its shell is the back) and trimmed to one
/// side. Below it the input is a solid and keeps its whole shell.
pub const SHEET_SHARE: f64 = 0.25;

/// Parameters of [`canonical`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SurfaceParams {
    /// Vertices the surface aims at, whatever the input's (default 10,000; between
    /// [`SurfaceParams::MIN_VERTICES`] and [`SurfaceParams::MAX_VERTICES`]). Raising it keeps
    /// finer detail and costs proportionally more in every later stage.
    pub vertices: usize,
    /// Offset radius r in grid spacings (default 1.0, at least 0.75). Gaps narrower than 2r
    /// close; raising it closes larger cracks between a soup's pieces and rounds more detail.
    pub offset: f64,
    /// Pieces of the result with less than this fraction of its area are dropped (default
    /// 0.002): specks around outliers of a scan.
    pub min_piece: f64,
}

impl SurfaceParams {
    /// Fewest vertices accepted.
    pub const MIN_VERTICES: usize = 500;
    /// Most vertices accepted (parameters may come from an index's profile: bounded work).
    pub const MAX_VERTICES: usize = 200_000;

    /// Checks the ranges documented on each field.
    pub fn validate(&self) -> Result<(), SurfaceError> {
        if !(Self::MIN_VERTICES..=Self::MAX_VERTICES).contains(&self.vertices) {
            return Err(SurfaceError::Params(format!(
                "the surface's vertices must be between {} and {}, got {}",
                Self::MIN_VERTICES,
                Self::MAX_VERTICES,
                self.vertices
            )));
        }
        if !(self.offset.is_finite() && (0.75..=4.0).contains(&self.offset)) {
            return Err(SurfaceError::Params(format!(
                "the offset must be between 0.75 and 4 grid spacings, got {}",
                self.offset
            )));
        }
        if !(self.min_piece.is_finite() && (0.0..0.5).contains(&self.min_piece)) {
            return Err(SurfaceError::Params(format!(
                "min_piece must be in [0, 0.5), got {}",
                self.min_piece
            )));
        }
        Ok(())
    }
}

impl Default for SurfaceParams {
    fn default() -> Self {
        SurfaceParams {
            vertices: 10_000,
            offset: 1.0,
            min_piece: 0.002,
        }
    }
}

/// What a canonical surface is made from.
#[derive(Debug, Clone, Copy)]
pub enum Input<'a> {
    /// A triangle mesh or soup (faces as wound in the file; a range grid triangulated).
    Mesh(&'a Mesh),
    /// Points without faces, with their normals when the file has them (any sign).
    Points {
        /// The points.
        positions: &'a [Point3<f64>],
        /// Their normals, if known.
        normals: Option<&'a [Vector3<f64>]>,
    },
}

/// A canonical surface and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// The surface: connected where the input is, about [`SurfaceParams::vertices`] vertices.
    pub mesh: Mesh,
    /// The grid spacing h, in the input's units.
    pub spacing: f64,
    /// The offset radius r, in the input's units.
    pub offset: f64,
    /// Faces left out as the back of an open sheet ([`trim`]).
    pub trimmed_faces: usize,
    /// Faces left out with pieces under [`SurfaceParams::min_piece`].
    pub dropped_faces: usize,
    /// Whether it was reconstructed from an offset volume (a soup, a point cloud, a mesh whose
    /// pieces are not clean and apart), rather than remeshed on the input's own faces.
    pub reconstructed: bool,
}

/// How densely a canonical surface is sampled: always relative to the area of the shape the
/// input stands for, so that a whole shape, a fragment of it and a scan of it are sampled at
/// the same density per unit of the source's area.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Density {
    /// The input stands for this share (in (0, 1]) of its source's area: about
    /// `share ×` [`SurfaceParams::vertices`] vertices (1 for a whole shape).
    Share(f64),
    /// [`SurfaceParams::vertices`] per this area (in the input's units squared, > 0): a
    /// collection in known units sampled at one density. The vertex count is kept within
    /// [`Density::UNIT_RANGE`] times the budget (a shape much larger or smaller than the unit
    /// is sampled more coarsely or finely than the others, with bounded work).
    UnitArea(f64),
}

impl Density {
    /// Bounds of the vertex count of [`Density::UnitArea`], as factors of
    /// [`SurfaceParams::vertices`].
    pub const UNIT_RANGE: (f64, f64) = (0.125, 4.0);
    /// Fewest vertices any density asks for.
    pub const MIN_TARGET: f64 = 200.0;

    /// Vertices to aim at for a surface of `area` under `params`.
    fn target(self, area: f64, params: &SurfaceParams) -> f64 {
        let v = params.vertices as f64;
        let t = match self {
            Density::Share(f) => v * f,
            Density::UnitArea(a) => {
                (v * area / a).clamp(v * Self::UNIT_RANGE.0, v * Self::UNIT_RANGE.1)
            }
        };
        if t.is_nan() {
            v
        } else {
            t.max(Self::MIN_TARGET)
        }
    }

    fn validate(self) -> Result<(), SurfaceError> {
        let ok = match self {
            Density::Share(f) => f.is_finite() && f > 0.0 && f <= 1.0,
            Density::UnitArea(a) => a.is_finite() && a > 0.0,
        };
        if ok {
            Ok(())
        } else {
            Err(SurfaceError::Params(format!(
                "the density must be a share in (0, 1] or a positive unit area, got {self:?}"
            )))
        }
    }
}

/// The canonical surface of `input` (see the module documentation), for a whole shape
/// ([`Density::Share`] 1).
pub fn canonical(input: Input, params: &SurfaceParams) -> Result<Surface, SurfaceError> {
    canonical_at(input, params, Density::Share(1.0))
}

/// The canonical surface of `input` sampled at `density`.
pub fn canonical_at(
    input: Input,
    params: &SurfaceParams,
    density: Density,
) -> Result<Surface, SurfaceError> {
    params.validate()?;
    density.validate()?;
    if let Input::Mesh(mesh) = input
        && let Some(surface) = remeshed_directly(mesh, params, density)?
    {
        return Ok(surface);
    }
    reconstruction(input, params, density)
}

/// Rounds of remeshing ([`remesh`](mod@remesh)) of a canonical surface: the low end of the
/// 5–10 Botsch and Kobbelt use, as split and collapse settle the vertex count within a few
/// rounds and every further round costs as much as the first.
pub const REMESH_ROUNDS: usize = 5;

/// The most faces remeshing may make for `target` vertices from a start of `faces` faces
/// ([`remesh::RemeshParams::max_faces`]): eight times the target's faces beyond the start's.
fn max_faces(target: f64, faces: usize) -> usize {
    faces + (16.0 * target) as usize
}

/// The target edge length for about `target` vertices on a surface of `area`: equilateral
/// triangles of side L, two per vertex, cover `area` when L² = 2·area / (√3·target).
fn edge_for(area: f64, target: f64) -> f64 {
    (2.0 * area / (3f64.sqrt() * target)).sqrt()
}

/// A clean mesh (edge- and vertex-manifold, consistently oriented, its pieces apart once
/// those under [`SurfaceParams::min_piece`] of the area are left out) remeshed on its own
/// faces; `None` for any other mesh.
fn remeshed_directly(
    mesh: &Mesh,
    params: &SurfaceParams,
    density: Density,
) -> Result<Option<Surface>, SurfaceError> {
    let area = geometry::total_area(mesh);
    if !(area.is_finite() && area > 0.0) {
        return Err(SurfaceError::NoArea);
    }
    let frame = Frame::of(mesh, area);
    let mesh = frame.entered(mesh);
    let target = density.target(area, params);
    let l = edge_for(1.0, target);
    let large = trim::LargePieces::of(&mesh, params.min_piece);
    let dropped = mesh.faces.len() - large.faces.len();
    let kept = Mesh {
        positions: mesh.positions,
        faces: large.faces,
    };
    let start = fill_small_holes(&kept, HOLE_PERIMETER * l);
    // remeshing needs an edge- and vertex-manifold, consistently oriented mesh: O(F log F),
    // before any sampling
    let Ok(he) = remesh::HalfEdges::new(&start) else {
        return Ok(None);
    };
    let closest = closest::ClosestPoint::new(&start);
    if large.pieces > 1 && pieces_touch(&kept, &large.label, &closest, 0.25 * l) {
        return Ok(None);
    }
    let remeshed = remesh::remesh(
        he,
        &remesh::RemeshParams {
            edge: l,
            iterations: REMESH_ROUNDS,
            max_faces: max_faces(target, start.faces.len()),
        },
        &closest,
    );
    Ok(Some(Surface {
        mesh: frame.left(remeshed),
        spacing: l * frame.unit,
        offset: 0.0,
        trimmed_faces: 0,
        dropped_faces: dropped,
        reconstructed: false,
    }))
}

/// The frame a surface is remeshed in: the lowest corner of the input's bounding box at the
/// origin, its area 1, coordinates rounded to a step of 2⁻²⁸. A scaled and moved copy of the
/// input lands on the same coordinates (but for the rare one within rounding of a step), so
/// remeshing makes the same choices and the copy gets the same surface, scaled and moved.
#[derive(Debug, Clone, Copy)]
struct Frame {
    origin: Point3<f64>,
    /// The input's length unit: the square root of its area.
    unit: f64,
}

impl Frame {
    /// Coordinates in the frame are multiples of this.
    const STEP: f64 = 1.0 / (1u64 << 28) as f64;

    fn of(mesh: &Mesh, area: f64) -> Frame {
        Frame {
            origin: geometry::bounding_box(mesh).min,
            unit: area.sqrt(),
        }
    }

    /// `mesh` in the frame: moved to the origin, scaled to unit area, coordinates quantised.
    fn entered(self, mesh: &Mesh) -> Mesh {
        let q = |x: f64| (x / Self::STEP).round() * Self::STEP;
        Mesh {
            positions: mesh
                .positions
                .iter()
                .map(|p| ((p - self.origin) / self.unit).map(q).into())
                .collect(),
            faces: mesh.faces.clone(),
        }
    }

    /// `mesh` back from the frame to the input's coordinates.
    fn left(self, mut mesh: Mesh) -> Mesh {
        for p in &mut mesh.positions {
            *p = self.origin + p.coords * self.unit;
        }
        mesh
    }
}

/// Holes whose boundary is shorter than this many target edge lengths (about two edges
/// across, below the surface's resolution) are closed before a clean mesh is remeshed.
pub const HOLE_PERIMETER: f64 = 6.0;

/// `mesh` (edge- and vertex-manifold, consistently oriented) with every hole whose boundary
/// loop is shorter than `max_perimeter` closed by a fan of triangles around a new vertex at the
/// loop's centroid.
fn fill_small_holes(mesh: &Mesh, max_perimeter: f64) -> Mesh {
    // the hole side of a boundary edge (a, b) of a face is (b, a); each boundary vertex of a
    // vertex-manifold mesh starts one such edge
    let directed = directed::Directed::new(mesh);
    let mut hole_next: std::collections::BTreeMap<u32, u32> = Default::default();
    for t in &mesh.faces {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            if directed.find(b, a).is_none() {
                hole_next.insert(b, a);
            }
        }
    }
    let mut out = mesh.clone();
    let mut done: std::collections::BTreeSet<u32> = Default::default();
    for &start in hole_next.keys() {
        if done.contains(&start) {
            continue;
        }
        let mut lp = vec![start];
        let mut v = start;
        while let Some(&n) = hole_next.get(&v) {
            if n == start || lp.len() > hole_next.len() {
                break;
            }
            lp.push(n);
            v = n;
        }
        done.extend(lp.iter().copied());
        let p = |v: u32| mesh.positions[v as usize];
        let perimeter: f64 = (0..lp.len())
            .map(|i| (p(lp[(i + 1) % lp.len()]) - p(lp[i])).norm())
            .sum();
        if lp.len() < 3 || perimeter >= max_perimeter {
            continue;
        }
        let c = lp.iter().fold(Vector3::zeros(), |s, &v| s + p(v).coords) / lp.len() as f64;
        let centre = out.positions.len() as u32;
        out.positions.push(Point3::from(c));
        for i in 0..lp.len() {
            out.faces.push([lp[i], lp[(i + 1) % lp.len()], centre]);
        }
    }
    out
}

/// Whether two pieces of `kept` (pieces by vertex `label`) touch or cross: samples every `gap`
/// on each piece, one of which then lies within `gap` of another piece's faces, searched in
/// `closest`, built on `kept` with faces appended (the fans that close small holes). Only faces
/// with another piece's face within `gap` of their circumscribing ball are sampled: no point of
/// any other face can be that near another piece.
fn pieces_touch(kept: &Mesh, label: &[u32], closest: &closest::ClosestPoint, gap: f64) -> bool {
    let face_piece: Vec<u32> = kept.faces.iter().map(|t| label[t[0] as usize]).collect();
    let near_other = |p: &Point3<f64>, own: u32, within: f64| {
        closest
            .nearest_among(p, within, |g| {
                face_piece.get(g as usize).is_some_and(|&q| q != own)
            })
            .is_some()
    };
    let candidates: Vec<[u32; 3]> = kept
        .faces
        .par_iter()
        .zip(&face_piece)
        .filter(|&(t, &own)| {
            let [a, b, c] = t.map(|v| kept.positions[v as usize]);
            let centre = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            let reach = [a, b, c]
                .iter()
                .map(|v| (v - centre).norm())
                .fold(0.0, f64::max);
            near_other(&centre, own, reach + gap)
        })
        .map(|(t, _)| *t)
        .collect();
    // each candidate sampled on its own, the first sample near another piece ends the search
    candidates
        .par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(stack, points), t| {
                points.clear();
                sample::bisected(t.map(|v| kept.positions[v as usize]), gap, stack, points);
                let own = label[t[0] as usize];
                points.iter().any(|p| near_other(p, own, gap))
            },
        )
        .any(|near| near)
}

/// The offset-volume reconstruction of `input` (steps 1–5 of the module docs), its spacing
/// corrected from the area it made.
fn reconstruction(
    input: Input,
    params: &SurfaceParams,
    density: Density,
) -> Result<Surface, SurfaceError> {
    let (first_area, bbox, orientation, cloud) = match input {
        Input::Mesh(mesh) => {
            let area = geometry::total_area(mesh);
            if !(area.is_finite() && area > 0.0) {
                return Err(SurfaceError::NoArea);
            }
            (
                area,
                geometry::bounding_box(mesh),
                orient::orient_faces(mesh),
                None,
            )
        }
        Input::Points { positions, normals } => {
            let cloud = normals::Cloud::new(positions, normals)?;
            (
                cloud.area_estimate(),
                cloud.bounding_box(),
                Vec::new(),
                Some(cloud),
            )
        }
    };
    let make = |h: f64| -> Result<Surface, SurfaceError> {
        let h_grid = bounded_spacing(&bbox, h, params);
        match (input, &cloud) {
            (Input::Mesh(mesh), _) => {
                let samples = sample::lattice(mesh, &orientation, 0.5 * h_grid)?;
                build(&samples, Some(mesh), h_grid, params.offset * h_grid, params)
            }
            (Input::Points { .. }, Some(cloud)) => {
                let (samples, gap) = cloud.samples(0.5 * h_grid);
                // the offset must bridge the gaps between points
                let r = (params.offset * h_grid).max(gap);
                build(&samples, None, h_grid, r, params)
            }
            (Input::Points { .. }, None) => Err(SurfaceError::NoArea),
        }
    };
    let mut h = spacing_for(first_area, density.target(first_area, params));
    let mut surface = make(h)?;
    // at most two corrections of the spacing, from the area actually made (a soup's hidden
    // faces are in the input's area, not in its outer surface; a cloud's area is an estimate)
    for _ in 0..2 {
        let made = geometry::total_area(&surface.mesh);
        let next = spacing_for(made, density.target(made, params));
        if next.is_nan() || next <= 0.0 || (next / h - 1.0).abs() < 0.15 {
            break;
        }
        h = next;
        surface = make(h)?;
    }
    Ok(surface)
}

/// Grid spacing for `target` vertices on a surface of `area`.
fn spacing_for(area: f64, target: f64) -> f64 {
    (NETS_DENSITY * area / target).sqrt()
}

/// `h`, made coarser when the grid over `bbox` would exceed [`MAX_NODES`].
fn bounded_spacing(bbox: &geometry::BoundingBox, h: f64, params: &SurfaceParams) -> f64 {
    let margin = 2.0 * volume::margin(params.offset.max(1.0) * h, h);
    let ext = bbox.max - bbox.min;
    let nodes = |h: f64| {
        [ext.x, ext.y, ext.z]
            .iter()
            .map(|e| ((e + margin) / h).ceil() + 2.0)
            .product::<f64>()
    };
    let n = nodes(h);
    if n > MAX_NODES as f64 {
        // nodes scale as h⁻³ (margins aside): one correction, then a little more if needed
        let mut g = h * (n / MAX_NODES as f64).cbrt();
        while nodes(g) > MAX_NODES as f64 {
            g *= 1.05;
        }
        g
    } else {
        h
    }
}

/// Offset volume, nets and trimming at spacing `h` and offset radius `r`.
fn build(
    samples: &sample::Samples,
    mesh: Option<&Mesh>,
    h: f64,
    r: f64,
    params: &SurfaceParams,
) -> Result<Surface, SurfaceError> {
    if samples.positions.is_empty() {
        return Err(SurfaceError::NoArea);
    }
    let vol = volume::Volume::new(samples, h, r)?;
    let (mut positions, faces) = nets::surface_nets(&vol);
    let nearest = trim::Nearest::new(samples);
    let trimmed = trim::one_sided(&vol, &nearest, &positions, &faces);
    // a solid's thin parts (a finger, a wing, a CAD model's single-sided panel) are sheets
    // too, but most of its shell is not: it stays closed
    let trimmed = if (trimmed.removed as f64) < SHEET_SHARE * faces.len() as f64 {
        trim::Trimmed {
            sheet: vec![false; faces.len()],
            faces,
            removed: 0,
        }
    } else {
        trimmed
    };
    let removed = trimmed.removed;
    trim::project(&mut positions, &trimmed.faces, &nearest, mesh, r);
    // projected onto a mesh, the skin wrapped around an open boundary collapses onto the
    // boundary edge; projected onto a cloud's tangent planes it lies flat beyond the edge
    let (faces, overhang) = match mesh {
        Some(_) => (trimmed.faces, 0),
        None => trim::drop_overhang(&positions, &nearest, trimmed, r),
    };
    let (mesh, dropped) = trim::drop_small_pieces(positions, faces, params.min_piece)?;
    Ok(Surface {
        mesh,
        spacing: h,
        offset: r,
        trimmed_faces: removed + overhang,
        dropped_faces: dropped,
        reconstructed: true,
    })
}

#[cfg(test)]
mod tests;
