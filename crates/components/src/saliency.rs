//! Key-components as the salient regions of the Harris response (the robust preset's
//! clustering; not in the paper, which clusters the keypoints' planar images with its
//! Algorithm 1).
//!
//! The paper finds key-components where Harris keypoints crowd: it embeds the keypoints in the
//! plane by SMACOF and groups them by Algorithm 1, whose greedy, order-dependent assignment
//! makes a few moved keypoints split or merge clusters, and a new tessellation of the same
//! surface moves keypoints by one or two edges. Here the crowding is measured on the surface
//! itself, as a smooth field, and a component is where that field has a prominent peak:
//!
//! 1. **Saliency.** The positive part of the Harris response, compressed as
//!    `ln(1 + h⁺/c)` ([`RESPONSE_FLOOR`] = c) so that one sharp tip does not drown every other
//!    feature, is averaged over geodesic neighbourhoods of length about √t by normalised
//!    convolution: it and the indicator of the vertices that have a response are each diffused
//!    for time t by one implicit heat step, `(M + tW) S = M f` (`keycomp_spectral::diffuse_all`:
//!    cotangent Laplacian, lumped masses), and the first is divided by the second (H. Knutsson,
//!    C.-F. Westin, "Normalized and differential convolution", CVPR 1993). The result is a
//!    mean response per unit area, a quantity of the surface, not of its vertices, and
//!    vertices without a response (a fragment's unknown border) neither add nor dilute.
//! 2. **Prominent peaks.** Vertices are added in decreasing S (ties: smaller id first) and
//!    joined by union–find along the edges; where two regions meet at a vertex v, the one with
//!    the lower peak p keeps its own peak only if `S(v) ≤ (1 − ρ)·S(p)`, its saddle at least
//!    the share ρ ([`SaliencyParams::prominence`]) below it; otherwise it merges into the
//!    higher one (persistence-based mode seeking, F. Chazal, L. J. Guibas, S. Y. Oudot, P.
//!    Skraba, "Persistence-based clustering in Riemannian manifolds", J. ACM 60(6), 2013,
//!    with the prominence relative to the peak's own height, so the rule does not depend on
//!    the response's units). A bump that noise or a new tessellation raises or lowers a little
//!    cannot become or stop being a peak.
//! 3. **Components.** The [`SaliencyParams::max_components`] highest peaks, each with the
//!    geodesic disc of radius r around it ([`SaliencyParams::radius`], fast marching; region
//!    growing in geodesic lengths, so that bending a limb does not change it): its vertices,
//!    the faces touching them, and the keypoints inside it as its cluster.
//!
//! Everything is in the unit of the detection (`t` in unit areas, r in unit lengths), so a
//! fragment analysed in its source's unit gets its source's components where it has them.
//! Cost: one sparse factorisation (about 10 ms at 10,000 vertices), a sort and union–find
//! (O(V log V)), and one bounded front per component; no geodesic matrix and no SMACOF.

use keycomp_geodesic::{GeodesicParams, GeodesicSolver};
use keycomp_mesh::{Mesh, Topology, VertexId};
use serde::{Deserialize, Serialize};

use crate::error::ComponentsError;

/// Parameters of the saliency clustering (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SaliencyParams {
    /// Diffusion time t of the response, in unit areas (> 0; default 0.02: neighbourhoods of
    /// about 0.14 unit lengths). Raising it merges nearby features into fewer, broader peaks.
    pub time: f64,
    /// Share of its own height by which a peak's saddle must lie below it (in (0, 1); default
    /// 0.4). Raising it keeps only the most distinct peaks (at 0.6 too few remain to repeat).
    pub prominence: f64,
    /// Geodesic radius of a component around its peak, in unit lengths (> 0; default 0.15, the
    /// paper's R of KC-1). Raising it gives larger components, which a displaced peak changes
    /// less.
    pub radius: f64,
    /// The highest peaks kept (≥ 1; default 12).
    pub max_components: usize,
}

impl Default for SaliencyParams {
    fn default() -> Self {
        SaliencyParams {
            time: 0.02,
            prominence: 0.4,
            radius: 0.15,
            max_components: 12,
        }
    }
}

impl SaliencyParams {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ComponentsError> {
        if !(self.time.is_finite() && self.time > 0.0 && self.time <= 10.0) {
            return Err(ComponentsError::param(
                "saliency.time",
                self.time,
                "must be a diffusion time in (0, 10] unit areas (default 0.02)",
            ));
        }
        if !(self.prominence > 0.0 && self.prominence < 1.0) {
            return Err(ComponentsError::param(
                "saliency.prominence",
                self.prominence,
                "must be a share in (0, 1) (default 0.4)",
            ));
        }
        if !(self.radius.is_finite() && self.radius > 0.0 && self.radius <= 10.0) {
            return Err(ComponentsError::param(
                "saliency.radius",
                self.radius,
                "must be a length in (0, 10] unit lengths (default 0.15)",
            ));
        }
        if !(1..=1000).contains(&self.max_components) {
            return Err(ComponentsError::param(
                "saliency.max_components",
                self.max_components,
                "must be between 1 and 1000 (default 12)",
            ));
        }
        Ok(())
    }
}

/// One salient component on the unit-area mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Salient {
    /// Its peak.
    pub peak: VertexId,
    /// The keypoints inside its disc (sorted ids).
    pub keypoints: Vec<VertexId>,
    /// The vertices of its disc (sorted).
    pub vertices: Vec<VertexId>,
    /// Faces touching one of them (sorted).
    pub faces: Vec<u32>,
    /// The largest geodesic distance from the peak of a vertex of the disc.
    pub reach: f64,
}

/// Below this value of the diffused weight a vertex is taken to have no response around it
/// (its saliency is 0).
const MIN_WEIGHT: f64 = 1e-6;

/// The saliency field of step 1: the compressed positive `response` (NaN for none) diffused
/// for `time` on `mesh`, normalised by the diffused weight of the vertices that have one.
///
/// Errors: the mesh has no face of positive area.
pub fn saliency(mesh: &Mesh, response: &[f64], time: f64) -> Result<Vec<f64>, ComponentsError> {
    let fail = |e: keycomp_spectral::SpectralError| ComponentsError::Degenerate {
        what: "saliency",
        detail: e.to_string(),
    };
    let lap = keycomp_spectral::Laplacian::new(mesh).map_err(fail)?;
    let n = mesh.num_vertices();
    let known: Vec<f64> = (0..n)
        .map(|v| match response.get(v) {
            Some(h) if h.is_finite() => 1.0,
            _ => 0.0,
        })
        .collect();
    let compressed: Vec<f64> = (0..n)
        .map(|v| match response.get(v) {
            Some(&h) if h.is_finite() => (h.max(0.0) / RESPONSE_FLOOR).ln_1p(),
            _ => 0.0,
        })
        .collect();
    let mut d = keycomp_spectral::diffuse_all(&lap, &[&compressed, &known], time)
        .map_err(fail)?
        .into_iter();
    let (value, weight) = (d.next().unwrap_or_default(), d.next().unwrap_or_default());
    Ok(value
        .iter()
        .zip(&weight)
        .map(|(&s, &w)| if w > MIN_WEIGHT { s / w } else { 0.0 })
        .collect())
}

/// The response level c of the compression `ln(1 + h⁺/c)` (in the unit-area frame Harris
/// works in): about the median positive response on an organic shape's canonical surface.
pub const RESPONSE_FLOOR: f64 = 1e4;

/// The prominent peaks of `field` on the vertex graph of `topo` (step 2), highest first
/// (ties: smaller id), with `prominence` the share of its height a peak's saddle must lie
/// below it. Vertices no edge reaches are their own peaks unless their value is not positive;
/// only vertices with a positive value can be peaks.
pub fn prominent_peaks(topo: &Topology, field: &[f64], prominence: f64) -> Vec<VertexId> {
    let n = field.len().min(topo.num_vertices());
    let mut order: Vec<VertexId> = (0..n as VertexId)
        .filter(|&v| field[v as usize].is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        field[b as usize]
            .total_cmp(&field[a as usize])
            .then(a.cmp(&b))
    });
    const UNSEEN: u32 = u32::MAX;
    let mut parent = vec![UNSEEN; n];
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        let mut root = x;
        while parent[root as usize] != root {
            root = parent[root as usize];
        }
        while parent[x as usize] != root {
            let next = parent[x as usize];
            parent[x as usize] = root;
            x = next;
        }
        root
    }
    // the region's peak is its root; a merged peak points into the higher region
    let mut roots: Vec<u32> = Vec::with_capacity(8);
    for &v in &order {
        parent[v as usize] = v;
        roots.clear();
        for &w in topo.neighbors(v) {
            if (w as usize) < n && parent[w as usize] != UNSEEN {
                let r = find(&mut parent, w);
                if !roots.contains(&r) {
                    roots.push(r);
                }
            }
        }
        if roots.is_empty() {
            continue;
        }
        // the highest region (ties: smaller id) takes v; the others keep their peak only if
        // v lies far enough below it
        roots.sort_by(|&a, &b| {
            field[b as usize]
                .total_cmp(&field[a as usize])
                .then(a.cmp(&b))
        });
        let top = roots[0];
        parent[v as usize] = top;
        let sv = field[v as usize];
        for &r in &roots[1..] {
            if sv > (1.0 - prominence) * field[r as usize] {
                parent[r as usize] = top;
            }
        }
    }
    let peaks: Vec<VertexId> = order
        .iter()
        .copied()
        .filter(|&v| parent[v as usize] == v && field[v as usize] > 0.0)
        .collect();
    // `order` is already highest first, each vertex once
    peaks
}

/// The salient components of the unit-area mesh `norm` (see the [module docs](self)) from its
/// Harris `response` and `keypoints`.
///
/// Errors: invalid parameters, or a mesh on which the diffusion or the fronts cannot run.
pub fn salient_components(
    norm: &Mesh,
    topo: &Topology,
    response: &[f64],
    keypoints: &[VertexId],
    params: &SaliencyParams,
) -> Result<Vec<Salient>, ComponentsError> {
    params.validate()?;
    let field = saliency(norm, response, params.time)?;
    let peaks = prominent_peaks(topo, &field, params.prominence);
    let solver =
        GeodesicSolver::with_params(norm, topo, GeodesicParams::default()).map_err(|e| {
            ComponentsError::Degenerate {
                what: "geodesic fronts",
                detail: e.to_string(),
            }
        })?;
    let mut ws = solver.workspace();
    let mut out = Vec::new();
    for &p in peaks.iter().take(params.max_components) {
        solver
            .solve_within(p, params.radius, &mut ws)
            .map_err(|e| ComponentsError::Degenerate {
                what: "geodesic fronts",
                detail: e.to_string(),
            })?;
        let mut vertices: Vec<VertexId> = ws
            .reached()
            .iter()
            .copied()
            .filter(|&v| ws.distance(v) <= params.radius)
            .collect();
        vertices.sort_unstable();
        vertices.dedup();
        let reach = vertices.iter().map(|&v| ws.distance(v)).fold(0.0, f64::max);
        let faces = topo.faces_touching(&vertices);
        let mut members: Vec<VertexId> = keypoints
            .iter()
            .copied()
            .filter(|v| vertices.binary_search(v).is_ok())
            .collect();
        members.sort_unstable();
        out.push(Salient {
            peak: p,
            keypoints: members,
            vertices,
            faces,
            reach,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    /// Two bumps of different heights with a deep valley between them are two peaks; a bump
    /// whose saddle is close to its height merges into the higher one.
    #[test]
    fn prominence_is_relative_to_the_peak() {
        let m = synth::grid(20, 1, 1.0); // a strip: vertices 0..=20 on the first row
        let t = Topology::new(&m);
        let row = |x: usize| -> f64 {
            let x = x as f64;
            (-((x - 5.0) / 1.5).powi(2)).exp() * 2.0 + (-((x - 15.0) / 1.5).powi(2)).exp()
        };
        let field: Vec<f64> = (0..m.num_vertices()).map(|v| row(v % 21)).collect();
        let peaks = prominent_peaks(&t, &field, 0.5);
        assert_eq!(peaks.len(), 2, "{peaks:?}");
        assert_eq!(peaks[0] % 21, 5);
        assert_eq!(peaks[1] % 21, 15);
        // the same bumps on a ridge: the second's saddle (2.0) lies less than half its height
        // (3.0) below it, so it merges
        let ridge: Vec<f64> = (0..m.num_vertices()).map(|v| row(v % 21) + 2.0).collect();
        assert_eq!(prominent_peaks(&t, &ridge, 0.5).len(), 1);
        // nothing positive, no peak
        assert!(prominent_peaks(&t, &vec![0.0; m.num_vertices()], 0.5).is_empty());
    }

    /// On a sphere with two bumps of Harris-like response, the components are geodesic discs
    /// of the given radius around them, holding the keypoints inside.
    #[test]
    fn components_are_geodesic_discs_around_the_peaks() {
        let (norm, _) = keycomp_mesh::geometry::normalize_unit_area(&synth::icosphere(4, 1.0));
        let t = Topology::new(&norm);
        let north = 0; // find the two poles by coordinates
        let top = (0..norm.num_vertices())
            .max_by(|&a, &b| norm.positions[a].z.total_cmp(&norm.positions[b].z))
            .unwrap();
        let bottom = (0..norm.num_vertices())
            .min_by(|&a, &b| norm.positions[a].z.total_cmp(&norm.positions[b].z))
            .unwrap();
        let _ = north;
        let mut response = vec![0.0; norm.num_vertices()];
        response[top] = 2.0;
        response[bottom] = 1.0;
        let params = SaliencyParams {
            radius: 0.1,
            ..SaliencyParams::default()
        };
        let keys = [top as VertexId, bottom as VertexId];
        let c = salient_components(&norm, &t, &response, &keys, &params).unwrap();
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].peak, top as VertexId);
        assert_eq!(c[1].peak, bottom as VertexId);
        for (s, k) in c.iter().zip(keys) {
            assert_eq!(s.keypoints, vec![k]);
            assert!(s.reach <= 0.1 && s.reach > 0.07, "{}", s.reach);
            // every vertex of the disc within the radius of the pole (chord ≤ arc)
            let pole = norm.positions[s.peak as usize];
            assert!(
                s.vertices
                    .iter()
                    .all(|&v| (norm.positions[v as usize] - pole).norm() <= 0.1 + 1e-12)
            );
        }
        let bad = SaliencyParams {
            prominence: 1.0,
            ..params
        };
        assert!(salient_components(&norm, &t, &response, &keys, &bad).is_err());
    }
}
