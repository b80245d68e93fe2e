//! SHREC'10-style mesh transformations with a ground-truth vertex correspondence.
//!
//! [`transform`] applies one [`Kind`] of perturbation at a strength S ∈ 1..=5 to a null shape and
//! returns the transformed mesh together with `map`: for every transformed vertex, the null
//! vertex it comes from (`None` where the transformation created it; none of the kinds below
//! creates vertices, so every entry is `Some`). The kinds follow the SHREC'10 robust feature
//! detection and description benchmark (A. M. Bronstein, M. M. Bronstein, B. Bustos, U. Castellani,
//! M. Crisani, B. Falcidieno, L. J. Guibas, I. Kokkinos, V. Murino, M. Ovsjanikov, G. Patané,
//! I. Sipiran, A. Spagnuolo, J. Sun, "SHREC 2010: robust feature detection and description
//! benchmark", Eurographics Workshop on 3D Object Retrieval (3DOR), 2010), as used by Sipiran &
//! Bustos (2013), Section 4.1. Isometry is not generated: it comes from real pose data.
//!
//! Sizes are relative to the shape so that a strength means the same on any mesh: lengths are
//! in units of L = √(surface area) (the length unit of the unit-area normalised shape), areas
//! are fractions of the surface area, counts are fractions of the referenced vertices.
//!
//! | kind | what | S = 1 | S = 2 | S = 3 | S = 4 | S = 5 |
//! |---|---|---|---|---|---|---|
//! | `holes` | 3 holes: vertices removed in order of graph-geodesic distance from 3 random centres (equal radii) until the removed barycentric area reaches the fraction; faces touching them dropped | 2 % of area | 4 % | 6 % | 8 % | 10 % |
//! | `microholes` | single random vertices removed with their star (faces of the 1-ring), at least 3 edges apart so holes never merge; count = max(10·S, 0.2 %·S of vertices) | 0.2 % of vertices (≥ 10) | 0.4 % (≥ 20) | 0.6 % (≥ 30) | 0.8 % (≥ 40) | 1.0 % (≥ 50) |
//! | `noise` | every vertex moved by isotropic Gaussian noise, σ per coordinate | σ = 0.001 L | 0.002 L | 0.003 L | 0.004 L | 0.005 L |
//! | `shotnoise` | a random fraction of the vertices (at least S) moved along the area-weighted vertex normal by ±0.02 L (random sign) | 1 % of vertices | 2 % | 3 % | 4 % | 5 % |
//! | `scale` | uniform scaling about the area-weighted centroid, factor (ordered by \|ln factor\|) | × 0.75 | × 1.5 | × 0.5 | × 2 | × 4 |
//! | `localscale` | graph-geodesic ball of radius r around a random vertex scaled × 1.5 about its area-weighted centroid; weight 1 up to r/2, smoothstep to 0 at r | r = 0.04 L | 0.08 L | 0.12 L | 0.16 L | 0.20 L |
//! | `topology` | 2·S handles welding parts that are close in space but far along the surface: vertices u, v within ε facing each other across free space and not connected through the surface inside the ball of radius 2·\|uv\| around u (so geodesic ≥ 3·\|uv\|); a face at u and one at v are replaced by a triangular tube (6 faces); ε = 0.01 L, doubled up to 0.16 L while sites are missing; error on shapes without such places | 2 handles | 4 | 6 | 8 | 10 |
//! | `sampling` | decimation by half-edge collapse, shortest edge first, the endpoint with the smaller quadric error (Garland & Heckbert 1997) kept; link condition, boundary and normal-flip checks keep a manifold input manifold | keep 80 % of vertices | 60 % | 40 % | 25 % | 12 % |
//!
//! Vertices keep their null positions in `holes`, `microholes`, `topology` and `sampling`
//! (removed vertices are dropped and the survivors renumbered in increasing null-id order);
//! `noise`, `shotnoise`, `scale` and `localscale` keep the connectivity and the map is the
//! identity.
//!
//! Randomness comes from a ChaCha8 generator seeded with the seed and the kind (not the
//! strength), so the output is a deterministic function of (null mesh, kind, strength, seed) and
//! strengths are nested for one seed: the same hole centres with growing radii, the same noise
//! direction with growing σ, the shot-noise vertices of S a prefix of those of S + 1, and so on.
//! `scale` and `sampling` use no randomness.
//!
//! Steps common to all kinds: validate S, measure the area A (error if 0), apply the kind,
//! validate the output through [`Mesh::from_raw`]. Complexity: O(|V| log |V|) for every kind
//! (Dijkstra, decimation heap), O(|V|) for noise and scale.

mod decimate;
mod displace;
mod holes;
mod mapfile;
mod weld;

use std::fmt;
use std::str::FromStr;

use keycomp_mesh::geometry::{total_area, vertex_areas};
use keycomp_mesh::{Mesh, Point3, Topology, Vector3, VertexId};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::BenchError;

pub use mapfile::{MapFile, format_map, parse_map, read_map, write_map};

/// The strongest transformation level.
pub const MAX_STRENGTH: u8 = 5;

/// A kind of transformation (see the table in the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Big holes.
    Holes,
    /// Many one-vertex holes.
    Microholes,
    /// Gaussian noise on every vertex.
    Noise,
    /// Large displacements along the normal of a few vertices.
    Shotnoise,
    /// Global uniform scaling.
    Scale,
    /// Scaling of one region with a smooth falloff.
    Localscale,
    /// Handles welding parts that are close in space.
    Topology,
    /// Down-sampling by edge-collapse decimation.
    Sampling,
}

impl Kind {
    /// All kinds, in the order of the module table.
    pub const ALL: [Kind; 8] = [
        Kind::Holes,
        Kind::Microholes,
        Kind::Noise,
        Kind::Shotnoise,
        Kind::Scale,
        Kind::Localscale,
        Kind::Topology,
        Kind::Sampling,
    ];

    /// The lowercase name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Holes => "holes",
            Kind::Microholes => "microholes",
            Kind::Noise => "noise",
            Kind::Shotnoise => "shotnoise",
            Kind::Scale => "scale",
            Kind::Localscale => "localscale",
            Kind::Topology => "topology",
            Kind::Sampling => "sampling",
        }
    }

    /// Whether the transformation keeps every surviving vertex at its null position.
    pub fn keeps_positions(self) -> bool {
        matches!(
            self,
            Kind::Holes | Kind::Microholes | Kind::Topology | Kind::Sampling
        )
    }

    /// A per-kind constant mixed into the seed so kinds draw independent random numbers.
    fn stream(self) -> u64 {
        (self as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kind {
    type Err = BenchError;

    /// Parses a lowercase name (ASCII case is ignored).
    fn from_str(s: &str) -> Result<Kind, BenchError> {
        Kind::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| BenchError::UnknownKind { name: s.to_owned() })
    }
}

/// A transformed shape and its correspondence to the null shape.
#[derive(Debug, Clone, PartialEq)]
pub struct Transformed {
    /// The transformed mesh (validated).
    pub mesh: Mesh,
    /// For each transformed vertex, the null vertex it comes from (`None` if created by the
    /// transformation). Same length as `mesh.positions`; every id is below the null vertex count.
    pub map: Vec<Option<VertexId>>,
}

/// Applies `kind` at `strength` (1..=5) to `null`, deterministically for `seed`.
///
/// Errors: [`BenchError::InvalidStrength`], [`BenchError::ZeroArea`],
/// [`BenchError::NothingToWeld`] (topology on a shape without nearby parts),
/// [`BenchError::InvalidOutput`] (the result has no face left).
pub fn transform(
    null: &Mesh,
    kind: Kind,
    strength: u8,
    seed: u64,
) -> Result<Transformed, BenchError> {
    if !(1..=MAX_STRENGTH).contains(&strength) {
        return Err(BenchError::InvalidStrength { strength });
    }
    let area = total_area(null);
    if !(area > 0.0 && area.is_finite()) {
        return Err(BenchError::ZeroArea);
    }
    let ctx = Context {
        null,
        unit: area.sqrt(),
        s: strength,
        kind,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ kind.stream());
    match kind {
        Kind::Holes => holes::holes(&ctx, &mut rng),
        Kind::Microholes => holes::microholes(&ctx, &mut rng),
        Kind::Noise => displace::noise(&ctx, &mut rng),
        Kind::Shotnoise => displace::shotnoise(&ctx, &mut rng),
        Kind::Scale => displace::scale(&ctx),
        Kind::Localscale => displace::localscale(&ctx, &mut rng),
        Kind::Topology => weld::topology(&ctx, &mut rng),
        Kind::Sampling => decimate::sampling(&ctx),
    }
}

/// What every kind needs to know.
struct Context<'a> {
    null: &'a Mesh,
    /// √(surface area): the length unit of the unit-area shape, in mesh units.
    unit: f64,
    /// Strength 1..=5.
    s: u8,
    kind: Kind,
}

impl Context<'_> {
    fn topology(&self) -> Topology {
        Topology::new(self.null)
    }

    /// Vertices that some face refers to, in increasing id order.
    fn referenced(&self) -> Vec<VertexId> {
        let mut used = vec![false; self.null.num_vertices()];
        for f in &self.null.faces {
            for &v in f {
                used[v as usize] = true;
            }
        }
        (0..used.len() as VertexId)
            .filter(|&v| used[v as usize])
            .collect()
    }

    fn vertex_areas(&self) -> Vec<f64> {
        vertex_areas(self.null)
    }

    /// Same connectivity, new positions, identity map.
    fn moved(&self, positions: Vec<Point3<f64>>) -> Result<Transformed, BenchError> {
        self.rebuilt(positions, self.null.faces.clone())
    }

    /// All vertices kept (identity map), the given positions and faces.
    fn rebuilt(
        &self,
        positions: Vec<Point3<f64>>,
        faces: Vec<[VertexId; 3]>,
    ) -> Result<Transformed, BenchError> {
        let n = positions.len();
        let (mesh, _) =
            Mesh::from_raw(positions, faces).map_err(|source| BenchError::InvalidOutput {
                kind: self.kind.name(),
                source,
            })?;
        Ok(Transformed {
            mesh,
            map: (0..n as VertexId).map(Some).collect(),
        })
    }

    /// Null positions, the given faces (null ids); vertices no face refers to are dropped and the
    /// rest renumbered in increasing null-id order.
    fn compacted(&self, faces: Vec<[VertexId; 3]>) -> Result<Transformed, BenchError> {
        let n = self.null.num_vertices();
        let mut new_id = vec![u32::MAX; n];
        for f in &faces {
            for &v in f {
                new_id[v as usize] = 0;
            }
        }
        let mut positions = Vec::new();
        let mut map = Vec::new();
        for (v, id) in new_id.iter_mut().enumerate() {
            if *id == 0 {
                *id = positions.len() as VertexId;
                positions.push(self.null.positions[v]);
                map.push(Some(v as VertexId));
            }
        }
        let faces = faces
            .into_iter()
            .map(|f| f.map(|v| new_id[v as usize]))
            .collect();
        let (mesh, _) =
            Mesh::from_raw(positions, faces).map_err(|source| BenchError::InvalidOutput {
                kind: self.kind.name(),
                source,
            })?;
        Ok(Transformed { mesh, map })
    }
}

/// Area-weighted vertex normals (unit length; zero for a vertex without faces).
fn vertex_normals(mesh: &Mesh) -> Vec<Vector3<f64>> {
    let mut n = vec![Vector3::zeros(); mesh.num_vertices()];
    for f in 0..mesh.num_faces() {
        let [a, b, c] = mesh.triangle(f);
        let fn_ = (b - a).cross(&(c - a)); // length = 2 · area
        for &v in &mesh.faces[f] {
            n[v as usize] += fn_;
        }
    }
    for v in &mut n {
        let l = v.norm();
        if l > 0.0 {
            *v /= l;
        }
    }
    n
}

/// Area-weighted centroid of the vertices `ids` (barycentric vertex areas as weights).
fn weighted_centroid(
    mesh: &Mesh,
    areas: &[f64],
    ids: impl Iterator<Item = VertexId>,
) -> Point3<f64> {
    let mut sum = Vector3::zeros();
    let mut w = 0.0;
    for v in ids {
        let a = areas[v as usize];
        sum += mesh.positions[v as usize].coords * a;
        w += a;
    }
    if w > 0.0 {
        Point3::from(sum / w)
    } else {
        Point3::origin()
    }
}

#[cfg(test)]
mod tests;
