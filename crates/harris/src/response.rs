//! Per-vertex Harris response (steps 1–5): neighbourhood, PCA frame, quadratic fit, response.

use keycomp_mesh::geometry::total_area;
use keycomp_mesh::{Mesh, Point3, Topology, VertexId};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rayon::prelude::*;

use crate::fit::{fit_quadratic_with, response_from_coefficients};
use crate::params::{HarrisParams, LengthReference, Neighborhood, UnitArea};
use crate::size::reference_length;

const UNMARKED: u32 = u32::MAX;

/// Per-thread buffers, reused for every vertex: nothing is allocated per vertex once they have
/// grown to the largest neighbourhood.
pub(crate) struct Scratch {
    /// Per vertex: its index in `verts` while it is in the current neighbourhood.
    slot: Vec<u32>,
    /// Neighbourhood vertices in breadth-first (ring) order, v first.
    verts: Vec<VertexId>,
    /// Edge-path length from v, parallel to `verts`.
    dist: Vec<f64>,
    /// Neighbourhood points in the local frame.
    local: Vec<Vector3<f64>>,
    /// Design matrix of the fit.
    qr: Vec<f64>,
}

impl Scratch {
    pub(crate) fn new(num_vertices: usize) -> Scratch {
        Scratch {
            slot: vec![UNMARKED; num_vertices],
            verts: Vec::with_capacity(64),
            dist: Vec::with_capacity(64),
            local: Vec::with_capacity(64),
            qr: Vec::with_capacity(64 * 7),
        }
    }
}

/// Mesh-wide quantities every vertex needs.
#[derive(Clone, Copy)]
pub(crate) struct Context<'a> {
    pub positions: &'a [Point3<f64>],
    pub topo: &'a Topology,
    /// Adaptive radius in the mesh's own units (None for fixed rings).
    pub radius: Option<f64>,
    /// Adaptive only: length of every directed edge, `edge_len[edge_start[v] + i]` for the
    /// i-th neighbour of v (computed once, so the per-vertex BFS takes no square roots).
    pub edge_start: &'a [u32],
    pub edge_len: &'a [f64],
    /// Rings to grow at least (adaptive: `min_rings`; fixed: the ring count).
    pub rings: usize,
    pub min_points: usize,
    /// Factor taking the mesh to unit surface area.
    pub unit_scale: f64,
    pub k: f64,
    /// No response where the neighbourhood reaches the boundary.
    pub skip_boundary: bool,
}

/// Edge lengths in [`Topology::neighbors`] order, and where each vertex's run starts; empty
/// for fixed-ring neighbourhoods (which never look at lengths).
pub(crate) fn edge_lengths(
    mesh: &Mesh,
    topo: &Topology,
    params: &HarrisParams,
) -> (Vec<u32>, Vec<f64>) {
    if !matches!(params.neighborhood, Neighborhood::Adaptive { .. }) {
        return (Vec::new(), Vec::new());
    }
    let n = topo.num_vertices().min(mesh.num_vertices());
    let mut start = Vec::with_capacity(n + 1);
    let mut total = 0u32;
    for v in 0..n as VertexId {
        start.push(total);
        total += topo.neighbors(v).len() as u32;
    }
    start.push(total);
    let mut len = vec![0.0; total as usize];
    let pos = &mesh.positions;
    let chunks: Vec<(usize, &mut [f64])> = {
        // split `len` at vertex boundaries into ~256-vertex pieces for rayon
        let mut out = Vec::new();
        let mut rest = len.as_mut_slice();
        let mut v = 0;
        while v < n {
            let w = (v + 256).min(n);
            let (head, tail) = rest.split_at_mut((start[w] - start[v]) as usize);
            out.push((v, head));
            rest = tail;
            v = w;
        }
        out
    };
    chunks.into_par_iter().for_each(|(v0, slice)| {
        let mut k = 0;
        let mut v = v0;
        while k < slice.len() {
            let pv = pos[v];
            for &w in topo.neighbors(v as VertexId) {
                slice[k] = (pos[w as usize] - pv).norm();
                k += 1;
            }
            v += 1;
        }
    });
    (start, len)
}

impl<'a> Context<'a> {
    /// `None` when the mesh has no usable area or extent (every response is then NaN).
    /// `edges` comes from [`edge_lengths`] with the same arguments.
    pub(crate) fn new(
        mesh: &'a Mesh,
        topo: &'a Topology,
        params: &HarrisParams,
        edges: &'a (Vec<u32>, Vec<f64>),
        unit: UnitArea,
    ) -> Option<Self> {
        let own = total_area(mesh);
        if own.is_nan() || own <= 0.0 {
            return None;
        }
        let area = unit.area(mesh);
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        let (radius, rings) = match params.neighborhood {
            Neighborhood::Adaptive { radius_fraction } => {
                let diag = match params.length_reference {
                    LengthReference::Unit => area.sqrt(),
                    other => reference_length(mesh, other),
                };
                if !diag.is_finite() {
                    return None;
                }
                (Some(radius_fraction * diag), params.min_rings.max(1))
            }
            Neighborhood::Rings(k) => (None, k.max(1)),
        };
        Some(Context {
            positions: &mesh.positions,
            topo,
            radius,
            edge_start: &edges.0,
            edge_len: &edges.1,
            rings,
            min_points: params.min_points.max(6),
            unit_scale: 1.0 / area.sqrt(),
            k: params.k,
            skip_boundary: params.skip_boundary,
        })
    }
}

/// Most points a neighbourhood gathers. Not in the paper: it bounds the work around vertices
/// of very high valence (the apex of a cone of thousands of triangles, the centre of a
/// fan-triangulated polygon), whose every neighbour would otherwise gather the whole fan and
/// fit a quadratic to it, making the cost quadratic in the valence. On the shared data the
/// largest neighbourhood has 457 points (KIDS, 60k vertices; median 20–34), so the bound
/// never binds on meshes of ordinary valence.
pub(crate) const MAX_NEIGHBOURHOOD_POINTS: usize = 1024;

/// Most edges a neighbourhood's growth looks at, so that scanning high-valence vertices whose
/// neighbours are already gathered is bounded too.
const MAX_EDGE_VISITS: usize = 16 * MAX_NEIGHBOURHOOD_POINTS;

/// Grows the neighbourhood of `v` into `s.verts` (step 1); returns the number of rings.
///
/// The neighbours of a vertex of valence above [`MAX_NEIGHBOURHOOD_POINTS`] are sampled
/// evenly (every k-th in the topology's order), and growth stops once the neighbourhood holds
/// [`MAX_NEIGHBOURHOOD_POINTS`] points or has looked at [`MAX_EDGE_VISITS`] edges: the work per
/// vertex is bounded whatever the mesh's valences.
fn neighbourhood(ctx: &Context, v: VertexId, s: &mut Scratch) -> usize {
    let adaptive = ctx.radius.is_some();
    s.verts.clear();
    s.dist.clear();
    s.verts.push(v);
    s.dist.push(0.0);
    s.slot[v as usize] = 0;
    let mut start = 0;
    let mut rings = 0;
    let mut visits = 0usize;
    let mut full = false;
    loop {
        let end = s.verts.len();
        'ring: for i in start..end {
            let u = s.verts[i];
            let du = s.dist[i];
            let nbrs = ctx.topo.neighbors(u);
            let lens = if adaptive {
                let e0 = ctx.edge_start[u as usize] as usize;
                &ctx.edge_len[e0..e0 + nbrs.len()]
            } else {
                &[][..]
            };
            let stride = nbrs.len().div_ceil(MAX_NEIGHBOURHOOD_POINTS).max(1);
            for (j, &w) in nbrs.iter().enumerate().step_by(stride) {
                visits += 1;
                if visits > MAX_EDGE_VISITS || s.verts.len() >= MAX_NEIGHBOURHOOD_POINTS {
                    full = true;
                    break 'ring;
                }
                let slot = s.slot[w as usize];
                let d = du + lens.get(j).copied().unwrap_or(0.0);
                if slot == UNMARKED {
                    s.slot[w as usize] = s.verts.len() as u32;
                    s.verts.push(w);
                    s.dist.push(d);
                } else if slot as usize >= end {
                    // already in the ring being built: keep the shortest outward path
                    let cur = &mut s.dist[slot as usize];
                    if d < *cur {
                        *cur = d;
                    }
                }
            }
        }
        if s.verts.len() == end {
            break; // the connected piece is exhausted
        }
        rings += 1;
        start = end;
        if full {
            break;
        }
        if rings < ctx.rings || s.verts.len() < ctx.min_points {
            continue;
        }
        match ctx.radius {
            None => break,
            Some(r) => {
                let ring_max = s.dist[end..].iter().fold(0.0f64, |m, &d| m.max(d));
                // a NaN radius stops here instead of growing over the whole piece
                if ring_max > r || r.is_nan() {
                    break;
                }
            }
        }
    }
    for &u in &s.verts {
        s.slot[u as usize] = UNMARKED;
    }
    rings
}

/// The local frame of a vertex and its fitted quadratic (for inspection and tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFit {
    /// Axes of the local frame in mesh coordinates, `[x, y, z]`: x the direction of largest
    /// variance of the neighbourhood, z (the normal) that of smallest, oriented so the vertex
    /// lies on its positive side relative to the neighbourhood's centroid; y = z × x.
    pub frame: [Vector3<f64>; 3],
    /// `[p1, …, p6]` of `z = p1/2·x² + p2·xy + p3/2·y² + p4·x + p5·y + p6`, in units of the
    /// mesh normalised to unit area, with the vertex at the origin.
    pub coefficients: [f64; 6],
    /// Vertices in the neighbourhood (v included).
    pub num_points: usize,
    /// Rings in the neighbourhood.
    pub rings: usize,
}

/// Steps 1–3 for one vertex; `None` when it has no response.
pub(crate) fn local_fit_with(ctx: &Context, v: VertexId, s: &mut Scratch) -> Option<LocalFit> {
    if ctx.topo.faces_of(v).is_empty() {
        return None;
    }
    let rings = neighbourhood(ctx, v, s);
    let n = s.verts.len();
    if n < ctx.min_points {
        return None;
    }
    if ctx.skip_boundary && s.verts.iter().any(|&u| ctx.topo.is_boundary(u)) {
        return None;
    }
    // Coordinates relative to v, on the unit-area scale (translation never enters).
    let pv = ctx.positions[v as usize];
    let sc = ctx.unit_scale;
    s.local.clear();
    s.local.extend(
        s.verts
            .iter()
            .map(|&u| (ctx.positions[u as usize] - pv) * sc),
    );
    let centroid = s.local.iter().sum::<Vector3<f64>>() / n as f64;
    let mut cov = Matrix3::zeros();
    for d in &s.local {
        let e = d - centroid;
        cov += e * e.transpose();
    }
    let eig = SymmetricEigen::new(cov);
    let ev = eig.eigenvalues;
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| ev[a].total_cmp(&ev[b]));
    let x: Vector3<f64> = eig.eigenvectors.column(order[2]).into_owned();
    let mut z: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    // Orientation: v (the origin here) on the positive side, i.e. (v − centroid)·z > 0. When v
    // is exactly on the centroid's plane, the largest component of z is made positive
    // (the response does not depend on this sign; it only makes the frame deterministic).
    let side = -centroid.dot(&z);
    let flip = if side != 0.0 {
        side < 0.0
    } else {
        let i = z.iamax();
        z[i] < 0.0
    };
    if flip {
        z = -z;
    }
    let y = z.cross(&x);
    for d in s.local.iter_mut() {
        *d = Vector3::new(x.dot(d), y.dot(d), z.dot(d));
    }
    let coefficients = fit_quadratic_with(&s.local, &mut s.qr)?;
    Some(LocalFit {
        frame: [x, y, z],
        coefficients,
        num_points: n,
        rings,
    })
}

/// The response of one vertex, NaN when it has none.
pub(crate) fn vertex_response(ctx: &Context, v: VertexId, s: &mut Scratch) -> f64 {
    match local_fit_with(ctx, v, s) {
        Some(f) => {
            let h = response_from_coefficients(&f.coefficients, ctx.k);
            if h.is_finite() { h } else { f64::NAN }
        }
        None => f64::NAN,
    }
}

/// `f` of every vertex, in parallel over vertices (rayon); each worker chunk owns one
/// [`Scratch`].
fn per_vertex<T: Clone + Send>(
    ctx: &Context,
    empty: T,
    f: impl Fn(&Context, VertexId, &mut Scratch) -> T + Sync,
) -> Vec<T> {
    let n = ctx.positions.len();
    let mut out = vec![empty; n];
    if n == 0 {
        return out;
    }
    // Enough chunks to balance the load, few enough that the O(|V|) scratch is cheap.
    let chunk = (n / (rayon::current_num_threads() * 16)).max(256);
    out.par_chunks_mut(chunk)
        .enumerate()
        .for_each(|(ci, slice)| {
            let mut s = Scratch::new(n);
            for (i, r) in slice.iter_mut().enumerate() {
                *r = f(ctx, (ci * chunk + i) as VertexId, &mut s);
            }
        });
    out
}

/// Every vertex's local fit (`None` where it has no response), in parallel over vertices.
pub(crate) fn all_fits(ctx: &Context) -> Vec<Option<LocalFit>> {
    per_vertex(ctx, None, local_fit_with)
}

/// All responses, in parallel over vertices.
pub(crate) fn all_responses(ctx: &Context) -> Vec<f64> {
    per_vertex(ctx, f64::NAN, vertex_response)
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    /// Around the apices of a double cone of 3000 sides, every neighbourhood is cut at
    /// [`MAX_NEIGHBOURHOOD_POINTS`] and still fits; on an ordinary mesh no neighbourhood comes
    /// near the bound, so the bound changes nothing there.
    #[test]
    fn neighbourhoods_are_bounded_around_huge_valences() {
        let params = HarrisParams::default();
        let mesh = synth::bicone(3000);
        let topo = Topology::new(&mesh);
        let fits = crate::local_fits(&mesh, &topo, &params);
        let sizes: Vec<usize> = fits.iter().flatten().map(|f| f.num_points).collect();
        assert!(sizes.len() > 2900, "{} fits", sizes.len());
        assert!(sizes.iter().all(|&n| n <= MAX_NEIGHBOURHOOD_POINTS));
        assert!(
            sizes.contains(&MAX_NEIGHBOURHOOD_POINTS),
            "the bound never bound"
        );
        let mesh = synth::icosphere(5, 1.0);
        let topo = Topology::new(&mesh);
        let fits = crate::local_fits(&mesh, &topo, &params);
        let largest = fits.iter().flatten().map(|f| f.num_points).max().unwrap();
        assert!(largest < MAX_NEIGHBOURHOOD_POINTS / 4, "{largest}");
    }
}
