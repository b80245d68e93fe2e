//! The canonical surface: what keycomp analyses instead of the file as it is.
//!
//! Detection and description follow the vertices they are given: Harris neighbourhoods,
//! keypoint budgets (1 % of the vertices), smoothing passes and part sizes all change with the
//! tessellation, and a triangle soup (a CAD model made of intersecting, separately modelled
//! pieces, with faces hidden inside the solid and inconsistent orientation) has no connected
//! surface for geodesics to run on. So every input — a mesh at any resolution, a soup, a range
//! scan, a bare point cloud — is first turned into one surface of a fixed density relative to
//! its own size, and only that surface is analysed:
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
//! h is chosen so that the result has about [`SurfaceParams::vertices`] vertices: from the
//! input's area (a point cloud's from its point spacing), then once more from the area of the
//! surface made when the first estimate missed by more than 15 % (a soup's hidden faces count
//! in its area but not in its outer surface). The grid is bounded by [`MAX_NODES`] nodes: an
//! input whose extent is huge for its area gets a coarser spacing instead of an unbounded
//! allocation.
//!
//! Cost: O(S·(R/h)³) for S samples (about 8·A/h², so O(V) for a budget of V vertices), the
//! flood fill and the nets in O(grid nodes), the trimming in O(V log S). Everything is
//! deterministic: no random numbers, and parallel loops write disjoint slices.

mod error;
pub mod nets;
pub mod normals;
pub mod orient;
pub mod sample;
pub mod trim;
pub mod volume;

pub use error::SurfaceError;
pub use trim::nearest_vertices;
pub use volume::MAX_NODES;

use keycomp_mesh::{Mesh, Point3, Vector3, geometry};
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
    })
}

#[cfg(test)]
mod tests;
