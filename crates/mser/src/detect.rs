//! Diffusion-geometric MSER and MSER key-components of a mesh, end to end (Sipiran & Bustos
//! 2013, Section 4.4 and Fig. 10; Litman, Bronstein & Bronstein 2011).
//!
//! # Steps
//!
//! 1. Normalise the mesh to unit area (as key-component detection does), keeping the scale.
//! 2. The `eigenpairs` smallest Laplace–Beltrami eigenpairs of the whole mesh
//!    ([`keycomp_spectral::Spectrum`]: cotangent Laplacian, lumped mass, shift-invert block
//!    Lanczos over a sparse Cholesky factorisation).
//! 3. **HKS keypoints** (paper, Section 4.4, step 2): `HKS_t` at `t = keypoint_time × area`
//!    (the paper's 0.1), a vertex is a keypoint if its value exceeds every other vertex of its
//!    2-ring; sorted best (highest HKS) first.
//! 4. **Weights** from the heat kernel `K_t` at `t = time × area` ([`Weighting`]): vertex
//!    weights `−ln K_t(v, v)` (the HKS) or edge weights `−ln K_t(u, v)` between neighbours;
//!    then mapped linearly onto `[0, 1]` (minimum → 0, maximum → 1).
//! 5. **Component tree** of the mesh graph with those weights ([`ComponentTree`]) and its
//!    **maximally stable components** ([`maximally_stable`]), area = lumped vertex mass.
//!    These are the MSER components (paper, Section 4.4, step 1; Table 5).
//! 6. **MSER key-components** (step 3; Table 6): the smallest-area set of MSER components
//!    covering every keypoint ([`covering_set`]).
//!
//! # Choices the papers leave open (and ours)
//!
//! Sipiran & Bustos ran Litman et al.'s own code, whose parameters they do not give; Litman et
//! al. describe vertex weights from the auto-diffusivity `K_t(v, v)` and edge weights from the
//! heat kernel between neighbours (a dissimilarity decreasing in `K_t(u, v)`). What we chose:
//!
//! - **Dissimilarity** `−ln K_t` rather than `1 / K_t`: the same tree (a monotone map of the
//!   weights does not change the tree), but scaling the shape adds a constant to the weights,
//!   and after the `[0, 1]` normalisation nothing depends on scale or on the units of `t`.
//!   Heat is high at protrusion tips, so the components grow from the tips (the lower level
//!   sets of `−ln K_t` are the upper level sets of the heat).
//! - **`Δ` relative to the weight range** (step 4's normalisation): an image MSER's `Δ` is a
//!   number of grey levels out of 256; ours is a fraction of the range of the weights.
//! - **One direction**: components grow from heat maxima (extremities) only; the opposite
//!   ordering (regions of little heat, image MSER's "MSER−") is not searched.
//! - **Time** `t = time × area` with default `time = 0.02`, **edge** weights by default, and the
//!   stability parameters of [`StableParams`] (Δ 0.1, area 1–50 %, variation ≤ 1, diversity
//!   0.5). Chosen by hand, not on the benchmark, with the `mser_explore` harness
//!   (`cargo bench -p keycomp-mser --bench mser_explore`): on
//!   `synth::protrusion_sphere(5, 0.8, 0.25)` every combination of edge/vertex weights,
//!   `time ∈ {0.005, 0.02, 0.1}` and `Δ ∈ {0.05, 0.15}` gives six MSER key-components, one
//!   per protrusion; on TOSCA `cat0` the defaults give six key-components covering its eight
//!   HKS keypoints — the four paws, the tail tip and the head (10 % of the surface, three
//!   keypoints) — and on KIDS `0001.null.0` the hands, feet and head (inspected on renders).
//!   A diversity of 0.2 leaves up to 40 nested near-copies per shape, 0.5 about 15. The
//!   paper's HKS keypoints keep their own `t = 0.1 × area`.
//! - **Areas** are lumped vertex masses (one third of the incident triangles' area).
//! - **Keypoints no component contains** are left uncovered (reported, not forced into a
//!   component).
//! - **Spectrum on the full mesh**: Litman et al. (and Sipiran & Bustos) simplified the meshes
//!   before detection because their eigenproblem was dense; a sparse shift-invert solver gets
//!   60 eigenpairs of a 28k-vertex TOSCA shape in about a second, so no proxy mesh is needed
//!   and components are vertex sets of the input mesh (no transfer between meshes).
//! - **Truncation**: `K_t` from `eigenpairs` terms; the neglected terms are below
//!   `exp(−λ_k t)`, with `λ_k ≈ 4πk / area` (Weyl) about `exp(−4πk · time)`: `3·10⁻⁷` for the
//!   defaults (k = 60, time = 0.02). Negative truncated values (impossible for the true
//!   kernel) are floored at `10⁻¹²` of the largest.
//!
//! # Complexity
//!
//! The spectrum dominates (see [`keycomp_spectral::spectrum`]); weights `O(|E| k)`; the tree
//! `O(|E| log |E|)`; selection `O(n log n + m²)`; covering `O(K m log n)` for `K` keypoints and
//! `m` components.

use std::time::Instant;

use keycomp_components::{Detection, KeyComponent, Timings, min_enclosing_sphere};
use keycomp_mesh::{Mesh, Point3, Topology, VertexId, geometry};
use keycomp_spectral::{Spectrum, SpectrumParams, hks_keypoints};
use serde::{Deserialize, Serialize};

use crate::error::{MserError, Result};
use crate::stable::{StableComponent, StableParams, maximally_stable};
use crate::tree::ComponentTree;

/// Which diffusion-geometric weights the component tree uses (Litman et al. 2011, Section 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Weighting {
    /// Vertex weights `−ln K_t(v, v)` (the heat kernel signature).
    Vertex,
    /// Edge weights `−ln K_t(u, v)` between mesh neighbours.
    Edge,
}

impl std::fmt::Display for Weighting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Weighting::Vertex => "vertex",
            Weighting::Edge => "edge",
        })
    }
}

impl std::str::FromStr for Weighting {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "vertex" => Ok(Weighting::Vertex),
            "edge" => Ok(Weighting::Edge),
            _ => Err(format!("unknown weighting '{s}' (vertex or edge)")),
        }
    }
}

/// All parameters of [`detect`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MserParams {
    /// Vertex or edge weights. Default edge.
    pub weighting: Weighting,
    /// Diffusion time of the weights as a fraction of the surface area (`t = time × area`).
    /// Default 0.02.
    pub time: f64,
    /// Diffusion time of the HKS keypoints as a fraction of the area. Default 0.1 (the paper).
    pub keypoint_time: f64,
    /// Laplace–Beltrami eigenpairs computed (the zero one included). Default 60.
    pub eigenpairs: usize,
    /// The stability criterion and filters (`delta` is a fraction of the weight range).
    pub stable: StableParams,
}

impl Default for MserParams {
    fn default() -> Self {
        MserParams {
            weighting: Weighting::Edge,
            time: 0.02,
            keypoint_time: 0.1,
            eigenpairs: 60,
            stable: StableParams::default(),
        }
    }
}

impl MserParams {
    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("time", self.time), ("keypoint_time", self.keypoint_time)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(MserError::InvalidParameter {
                    name,
                    value: v.to_string(),
                    reason: "must be a positive fraction of the surface area",
                });
            }
        }
        if self.eigenpairs < 2 {
            return Err(MserError::InvalidParameter {
                name: "eigenpairs",
                value: self.eigenpairs.to_string(),
                reason: "must be at least 2 (100 is a good default)",
            });
        }
        self.stable.validate()
    }
}

/// What to report as components: every maximally stable component or the covering set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Output {
    /// All maximally stable components (the paper's "MSER", Table 5).
    All,
    /// The MSER key-components (Table 6).
    KeyComponents,
}

/// Wall-clock time of each stage, in milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MserTimings {
    /// Normalisation and the Laplace–Beltrami eigenpairs.
    pub spectrum: f64,
    /// HKS and its 2-ring maxima.
    pub keypoints: f64,
    /// Weights, component tree and maximally stable components.
    pub mser: f64,
    /// The covering set.
    pub select: f64,
}

/// The result of [`detect`].
#[derive(Debug, Clone, PartialEq)]
pub struct MserDetection {
    /// Total surface area in file units squared.
    pub area: f64,
    /// The normalisation factor s (normalised = s · file coordinates).
    pub scale: f64,
    /// `HKS_t` at the keypoint time, per vertex, on the unit-area mesh.
    pub hks: Vec<f64>,
    /// HKS keypoints, highest HKS first.
    pub keypoints: Vec<VertexId>,
    /// The maximally stable components, most stable first: sorted vertex ids.
    pub components: Vec<Vec<VertexId>>,
    /// Their tree measures (same order; `area` as a fraction of the total).
    pub stable: Vec<StableComponent>,
    /// Indices into `components` of the MSER key-components, increasing.
    pub key_components: Vec<usize>,
    /// Keypoints in no MSER component (sorted).
    pub uncovered: Vec<VertexId>,
    /// Eigenpairs computed.
    pub eigenpairs: usize,
    /// Time per stage.
    pub timings: MserTimings,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Undirected mesh edges `(u, v)` with `u < v`, in increasing order.
fn mesh_edges(topo: &Topology) -> Vec<(VertexId, VertexId)> {
    let mut out = Vec::new();
    for u in 0..topo.num_vertices() as VertexId {
        for &v in topo.neighbors(u) {
            if v > u {
                out.push((u, v));
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// `−ln K` floored at `10⁻¹²` of the largest positive value, mapped onto `[0, 1]`; `NaN` stays
/// `NaN` (absent).
fn normalized_log_weights(kernel: &[f64]) -> Vec<f64> {
    let kmax = kernel
        .iter()
        .copied()
        .filter(|k| k.is_finite())
        .fold(0.0f64, f64::max);
    if kmax <= 0.0 {
        return vec![f64::NAN; kernel.len()];
    }
    let floor = kmax * 1e-12;
    let logs: Vec<f64> = kernel
        .iter()
        .map(|&k| {
            if k.is_nan() {
                f64::NAN
            } else {
                -k.max(floor).ln()
            }
        })
        .collect();
    let (lo, hi) = logs
        .iter()
        .filter(|w| !w.is_nan())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &w| {
            (a.min(w), b.max(w))
        });
    let span = hi - lo;
    logs.iter()
        .map(|&w| {
            if w.is_nan() {
                f64::NAN
            } else if span > 0.0 {
                (w - lo) / span
            } else {
                0.0
            }
        })
        .collect()
}

/// The heat kernel `K_t(u, v)` for every pair in `edges`.
fn edge_kernel(spectrum: &Spectrum, t: f64, edges: &[(VertexId, VertexId)]) -> Vec<f64> {
    let mut acc = vec![0.0; edges.len()];
    for (i, &lambda) in spectrum.eigenvalues().iter().enumerate() {
        let w = (-lambda * t).exp();
        if w == 0.0 {
            break;
        }
        let phi = spectrum.eigenvector(i);
        for (a, &(u, v)) in acc.iter_mut().zip(edges) {
            *a += w * phi[u as usize] * phi[v as usize];
        }
    }
    acc
}

/// The diffusion-geometric component tree of `mesh` from its `spectrum` (computed on the same
/// mesh), at diffusion time `t` (mesh units squared), with normalised `−ln K_t` weights (see
/// the [module docs](self)). Vertex areas are the spectrum's lumped masses; vertices that no
/// face uses are left out.
///
/// Errors: `spectrum` was computed on another mesh (different vertex count).
pub fn diffusion_tree(
    topo: &Topology,
    spectrum: &Spectrum,
    weighting: Weighting,
    t: f64,
) -> Result<ComponentTree> {
    let n = topo.num_vertices();
    if spectrum.num_vertices() != n {
        return Err(MserError::LengthMismatch {
            what: "spectrum",
            found: spectrum.num_vertices(),
            expected: n,
        });
    }
    let masses = spectrum.masses();
    let edges = mesh_edges(topo);
    match weighting {
        Weighting::Vertex => {
            let mut hks = spectrum.hks(t);
            for (h, &m) in hks.iter_mut().zip(masses) {
                if m <= 0.0 {
                    *h = f64::NAN;
                }
            }
            let w = normalized_log_weights(&hks);
            ComponentTree::vertex_weighted(&w, masses, &edges)
        }
        Weighting::Edge => {
            let k = edge_kernel(spectrum, t, &edges);
            let w = normalized_log_weights(&k);
            let levelled: Vec<(VertexId, VertexId, f64)> =
                edges.iter().zip(w).map(|(&(u, v), w)| (u, v, w)).collect();
            ComponentTree::edge_weighted(masses, &levelled)
        }
    }
}

/// Whether sorted `small` is a subset of sorted `big`.
fn is_subset(small: &[VertexId], big: &[VertexId]) -> bool {
    if small.len() > big.len() {
        return false;
    }
    let mut j = 0;
    for &x in small {
        while j < big.len() && big[j] < x {
            j += 1;
        }
        if j == big.len() || big[j] != x {
            return false;
        }
        j += 1;
    }
    true
}

/// The MSER key-components (Sipiran & Bustos 2013, Section 4.4, step 3): the smallest-area set
/// of `components` (sorted vertex lists, with their `areas`) covering every keypoint that some
/// component contains.
///
/// Each keypoint takes the smallest-area component containing it (ties: the lower index); then
/// a chosen component inside another chosen one is dropped (it covers nothing the larger one
/// does not). For a nested-or-disjoint family — the maximally stable components of one
/// component tree are — this is the minimum total-area cover: every cover must contain, for
/// each keypoint, a superset of that keypoint's smallest component, the kept components are
/// pairwise disjoint, so their total area is a lower bound that they attain.
///
/// Returns the chosen indices (increasing) and the keypoints no component contains (sorted).
///
/// Errors: `areas` and `components` differ in length.
pub fn covering_set(
    components: &[Vec<VertexId>],
    areas: &[f64],
    keypoints: &[VertexId],
) -> Result<(Vec<usize>, Vec<VertexId>)> {
    if areas.len() != components.len() {
        return Err(MserError::LengthMismatch {
            what: "component areas",
            found: areas.len(),
            expected: components.len(),
        });
    }
    let mut chosen = Vec::new();
    let mut uncovered = Vec::new();
    for &k in keypoints {
        let best = components
            .iter()
            .enumerate()
            .filter(|(_, c)| c.binary_search(&k).is_ok())
            .min_by(|(i, _), (j, _)| areas[*i].total_cmp(&areas[*j]).then(i.cmp(j)));
        match best {
            Some((i, _)) => chosen.push(i),
            None => uncovered.push(k),
        }
    }
    chosen.sort_unstable();
    chosen.dedup();
    uncovered.sort_unstable();
    uncovered.dedup();
    let kept: Vec<usize> = chosen
        .iter()
        .copied()
        .filter(|&i| {
            !chosen.iter().any(|&j| {
                j != i
                    && is_subset(&components[i], &components[j])
                    // equal sets: keep the lower index
                    && (components[i].len() < components[j].len() || j < i)
            })
        })
        .collect();
    Ok((kept, uncovered))
}

/// Diffusion-geometric MSER and MSER key-components of `mesh` (see the [module docs](self)).
///
/// Errors: invalid parameters, or a mesh the spectrum cannot be computed on (no surface,
/// degenerate factorisation, no convergence).
pub fn detect(mesh: &Mesh, params: &MserParams) -> Result<MserDetection> {
    params.validate()?;
    let t = Instant::now();
    let area = geometry::total_area(mesh);
    let (norm, scale) = geometry::normalize_unit_area(mesh);
    let topo = Topology::new(&norm);
    let spectrum = Spectrum::compute(
        &norm,
        &SpectrumParams {
            count: params.eigenpairs,
            ..SpectrumParams::default()
        },
    )?;
    let t_spectrum = ms(t);

    let t = Instant::now();
    let unit = spectrum.area();
    let hks = spectrum.hks(params.keypoint_time * unit);
    let mut keypoints = hks_keypoints(&norm, &topo, &hks)?;
    keypoints.sort_by(|&a, &b| hks[b as usize].total_cmp(&hks[a as usize]).then(a.cmp(&b)));
    let t_keypoints = ms(t);

    let t = Instant::now();
    let tree = diffusion_tree(&topo, &spectrum, params.weighting, params.time * unit)?;
    let stable = maximally_stable(&tree, &params.stable)?;
    let components: Vec<Vec<VertexId>> = stable
        .iter()
        .map(|s| tree.sorted_vertices(s.node))
        .collect();
    let t_mser = ms(t);

    let t = Instant::now();
    let areas: Vec<f64> = stable.iter().map(|s| s.area).collect();
    let (key_components, uncovered) = covering_set(&components, &areas, &keypoints)?;
    let t_select = ms(t);

    Ok(MserDetection {
        area,
        scale,
        hks,
        keypoints,
        components,
        stable,
        key_components,
        uncovered,
        eigenpairs: spectrum.len(),
        timings: MserTimings {
            spectrum: t_spectrum,
            keypoints: t_keypoints,
            mser: t_mser,
            select: t_select,
        },
    })
}

impl MserDetection {
    /// The vertex sets reported for `output`: every component, or the key-components.
    pub fn selected(&self, output: Output) -> Vec<&[VertexId]> {
        match output {
            Output::All => self.components.iter().map(Vec::as_slice).collect(),
            Output::KeyComponents => self
                .key_components
                .iter()
                .map(|&i| self.components[i].as_slice())
                .collect(),
        }
    }

    /// This detection in the struct of key-component detection
    /// ([`keycomp_components::Detection`]), so that the CLI and the benchmark treat both
    /// methods alike. `mesh` must be the mesh given to [`detect`].
    ///
    /// Per component: `vertices` as detected; `faces` every face touching one of them and
    /// `area` their area as a fraction of the total (the definitions of key-components);
    /// `keypoints` the HKS keypoints inside; `center` its vertex of highest HKS; the sphere the
    /// smallest one enclosing its vertices (file units). Detection-wide: `response` is the HKS
    /// at the keypoint time, `keypoints` the HKS keypoints, `unclustered` the keypoints in no
    /// reported component, `embedding` empty, `geodesic_vertices` 0 (no geodesics), and `timings` zero (the stages differ: see
    /// [`MserDetection::timings`]).
    ///
    /// Errors: `mesh` has a different vertex count, or non-finite coordinates.
    pub fn to_detection(&self, mesh: &Mesh, output: Output) -> Result<Detection> {
        if mesh.num_vertices() != self.hks.len() {
            return Err(MserError::LengthMismatch {
                what: "mesh",
                found: mesh.num_vertices(),
                expected: self.hks.len(),
            });
        }
        let topo = Topology::new(mesh);
        let face_areas = geometry::face_areas(mesh);
        let total: f64 = face_areas.iter().sum();
        let mut components = Vec::new();
        for (id, verts) in self.selected(output).into_iter().enumerate() {
            let faces = topo.faces_touching(verts);
            let area: f64 = faces.iter().map(|&f| face_areas[f as usize]).sum();
            let points: Vec<Point3<f64>> =
                verts.iter().map(|&v| mesh.positions[v as usize]).collect();
            let sphere = min_enclosing_sphere(&points)?;
            let center = verts
                .iter()
                .copied()
                .max_by(|&a, &b| {
                    self.hks[a as usize]
                        .total_cmp(&self.hks[b as usize])
                        .then(b.cmp(&a))
                })
                .unwrap_or_default();
            let mut keypoints: Vec<VertexId> = self
                .keypoints
                .iter()
                .copied()
                .filter(|k| verts.binary_search(k).is_ok())
                .collect();
            keypoints.sort_unstable();
            components.push(KeyComponent {
                id,
                center,
                sphere_center: sphere.center.coords.into(),
                sphere_radius: sphere.radius,
                keypoints,
                vertices: verts.to_vec(),
                faces,
                area: if total > 0.0 { area / total } else { 0.0 },
                missed_keypoints: Vec::new(),
            });
        }
        Ok(Detection::without_embedding(
            self.area,
            self.scale,
            self.hks.clone(),
            self.keypoints.clone(),
            components,
            Timings::default(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covering_set_is_the_smallest_cover() {
        let comps: Vec<Vec<VertexId>> = vec![
            vec![0, 1, 2, 3, 4, 5],
            vec![0, 1],
            vec![2, 3],
            vec![4],
            vec![6, 7],
        ];
        let areas: Vec<f64> = comps.iter().map(|c| c.len() as f64).collect();
        // 0 → {0,1}, 3 → {2,3}, 5 → the big one, which contains both: only it stays
        let (kept, uncovered) = covering_set(&comps, &areas, &[0, 3, 5, 9]).unwrap();
        assert_eq!(kept, vec![0]);
        assert_eq!(uncovered, vec![9]);
        // without 5, the two small ones cover
        let (kept, uncovered) = covering_set(&comps, &areas, &[3, 0, 7]).unwrap();
        assert_eq!(kept, vec![1, 2, 4]);
        assert!(uncovered.is_empty());
        // equal sets: the lower index stays
        let twins = vec![vec![1, 2], vec![1, 2]];
        let (kept, _) = covering_set(&twins, &[2.0, 2.0], &[1]).unwrap();
        assert_eq!(kept, vec![0]);
        assert!(covering_set(&comps, &[1.0], &[0]).is_err());
    }

    #[test]
    fn log_weights_are_normalised_and_floor_negative_heat() {
        let w = normalized_log_weights(&[1.0, f64::NAN, 0.1, -5.0]);
        assert_eq!(w[0], 0.0);
        assert!(w[1].is_nan());
        // −ln(1e-12) is the floor: the maximum weight
        assert_eq!(w[3], 1.0);
        assert!((w[2] - 10f64.ln() / 1e12f64.ln()).abs() < 1e-12);
        assert!(
            normalized_log_weights(&[2.0, 2.0])
                .iter()
                .all(|&x| x == 0.0)
        );
    }
}
