//! Describing a shape ([`describe_with`], [`describe_all`]): the steps in order (the surface,
//! the parts, their fronts, their descriptors), then the layout (the geodesic distances
//! between the parts' centres, symmetrised) and a surface sample for geometric verification
//! ([`ShapeDescription`]).

use std::collections::HashMap;

use keycomp_components::Detection;
use keycomp_mesh::Mesh;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::descriptor::{Descriptor, describe_part};
use crate::error::DescribeError;
use crate::fronts::Fronts;
use crate::levels::{choose_parts, whole_level};
use crate::params::{
    DescribeParams, MAX_LEVELS, MAX_PATCHES_PER_LEVEL, MAX_SMOOTHING_ITERATIONS, Units,
};
use crate::proxy::{OnProxy, on_proxy};
use crate::surface::{Surface, prepare};

/// Points of a description's surface sample ([`ShapeDescription::sample`]).
pub const SAMPLE_POINTS: usize = 512;

/// Seed of the surface sample's random stream.
pub const SAMPLE_SEED: u64 = 0x005a_3b1e;

/// Layout entry of a pair of parts without a meaningful distance (the whole-surface part).
pub const NO_DISTANCE: f32 = -1.0;

/// One described part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComponentDescription {
    /// The descriptor (see [`Descriptor`]).
    #[serde(with = "serde_big_array::BigArray")]
    pub descriptor: Descriptor,
    /// The part's centre (vertex id).
    pub center: u32,
    /// Position of the centre in the layout's frame and length unit (the mesh scaled as
    /// [`DescribeParams::units`] says, then smoothed): what matching's pose check compares.
    pub position: [f32; 3],
    /// Area of the part as a fraction of the shape's area.
    pub area: f64,
    /// Number of detection keypoints in the part.
    pub keypoints: usize,
    /// Largest geodesic distance from the centre to a vertex of the part, in the length unit.
    pub radius: f64,
    /// 0: a key-component of the detection; 1..=L: a patch of level L; L + 1: the whole
    /// surface (see the crate documentation, *Parts*).
    pub level: u8,
    /// The part's vertices.
    pub vertices: Vec<u32>,
}

/// A shape's parts and their layout.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeDescription {
    /// Key-components first (in detection order), then patches level by level, then the whole
    /// surface.
    pub components: Vec<ComponentDescription>,
    /// Geodesic distances between part centres, `m × m` row-major, in the length unit
    /// (symmetrised; pairs on different connected pieces get twice the largest finite value;
    /// pairs with the whole-surface part get [`NO_DISTANCE`]).
    pub layout: Vec<f32>,
    /// [`SAMPLE_POINTS`] points drawn uniformly by area on the described surface, in the
    /// frame and length unit of the parts' positions (for geometric verification: aligning a
    /// query onto a shape and measuring how much of it lies on the shape); empty for a mesh
    /// without area.
    pub sample: Vec<[f32; 3]>,
    /// Vertices on the mesh's boundary: 0 for a closed surface, more for a fragment or a scan.
    pub boundary_vertices: usize,
}

impl ShapeDescription {
    /// Distance between the centres of components `i` and `j`.
    pub fn layout_distance(&self, i: usize, j: usize) -> f32 {
        self.layout[i * self.components.len() + j]
    }
}

/// Describes every key-component of `det`, which must be the detection of `mesh`, with the
/// default [`DescribeParams`].
pub fn describe(mesh: &Mesh, det: &Detection) -> Result<ShapeDescription, DescribeError> {
    describe_with(mesh, det, &DescribeParams::default())
}

/// Describes the parts of `mesh` (see the crate documentation, *Parts*): the key-components of
/// `det`, which must be the detection of `mesh`, patches around its keypoints at every level, and
/// the whole surface.
pub fn describe_with(
    mesh: &Mesh,
    det: &Detection,
    params: &DescribeParams,
) -> Result<ShapeDescription, DescribeError> {
    describe_all(mesh, det, std::slice::from_ref(params))?
        .pop()
        .ok_or_else(|| DescribeError::Params("no description parameters".into()))
}

/// [`describe_with`] under each of `all`, in order (a query's scale hypotheses,
/// [`DescribeParams::for_query`]); none for an empty `all`. Parameters that differ from the
/// first only in their levels share its smoothed surface, Harris fits and geodesic fronts,
/// computed once: another ladder of radii costs only the fronts of its new patch centres.
/// Other parameters are described on their own.
pub fn describe_all(
    mesh: &Mesh,
    det: &Detection,
    all: &[DescribeParams],
) -> Result<Vec<ShapeDescription>, DescribeError> {
    let Some(first) = all.first() else {
        return Ok(Vec::new());
    };
    for params in all {
        check(mesh, det, params)?;
    }
    let proxy = on_proxy(mesh, det, first);
    let (on_mesh, on_det) = proxy.as_ref().map_or((mesh, det), |p| (&p.mesh, &p.det));
    let (surface, boundary, solver) = prepare(on_mesh, on_det, first)?;
    let fronts = Fronts::new(&solver);
    all.iter()
        .map(|params| {
            let same_surface = DescribeParams {
                levels: params.levels.clone(),
                ..first.clone()
            } == *params;
            if same_surface {
                let desc = describe_parts(&surface, &boundary, on_det, params, &fronts)?;
                Ok(match &proxy {
                    Some(p) => lift(desc, p, det, whole_level(params)),
                    None => desc,
                })
            } else {
                describe_with(mesh, det, params)
            }
        })
        .collect()
}

/// `desc`, described on the proxy `on`, in the input's vertex ids (crate documentation,
/// *Proxy*): a centre is a survivor and keeps its input id, a patch holds the input vertices
/// its survivors stand for, a key-component its own vertices (from `det`, the input's
/// detection) and the whole surface (level `whole_level`) all of them.
fn lift(
    mut desc: ShapeDescription,
    on: &OnProxy,
    det: &Detection,
    whole_level: u8,
) -> ShapeDescription {
    for part in &mut desc.components {
        let center = on.input_vertex(part.center);
        part.vertices = if part.level == 0 {
            det.components
                .iter()
                .find(|c| c.center == center)
                .map_or_else(Vec::new, |c| c.vertices.clone())
        } else if part.level == whole_level {
            (0..on.n as u32).collect()
        } else {
            on.input_vertices(&part.vertices)
        };
        part.center = center;
    }
    desc.boundary_vertices = on.boundary_vertices;
    desc
}

/// Refuses a detection that is not `mesh`'s and parameters that ask for unbounded work.
fn check(mesh: &Mesh, det: &Detection, params: &DescribeParams) -> Result<(), DescribeError> {
    let n = mesh.num_vertices();
    for &v in det
        .components
        .iter()
        .flat_map(|c| c.vertices.iter().chain(std::iter::once(&c.center)))
        .chain(&det.keypoints)
    {
        if v as usize >= n {
            return Err(DescribeError::Mismatch {
                vertex: v,
                vertices: n,
            });
        }
    }
    // the parameters may come from an index's profile: bound the work and memory they ask for
    // (one front of |V| distances is kept per part centre)
    if params.levels.len() > MAX_LEVELS
        || params.levels.iter().any(|r| !(r.is_finite() && *r > 0.0))
    {
        return Err(DescribeError::Params(format!(
            "levels must be at most {MAX_LEVELS} positive radii, got {:?}",
            params.levels
        )));
    }
    if params.patches_per_level > MAX_PATCHES_PER_LEVEL {
        return Err(DescribeError::Params(format!(
            "at most {MAX_PATCHES_PER_LEVEL} patches per level, got {}",
            params.patches_per_level
        )));
    }
    if params.smoothing_iterations > MAX_SMOOTHING_ITERATIONS {
        return Err(DescribeError::Params(format!(
            "at most {MAX_SMOOTHING_ITERATIONS} smoothing iterations, got {}",
            params.smoothing_iterations
        )));
    }
    let min = keycomp_components::GeodesicOptions::MIN_PROXY_VERTICES;
    if params.proxy_vertices != 0 && params.proxy_vertices < min {
        return Err(DescribeError::Params(format!(
            "the proxy's vertex budget must be 0 or at least {min}, got {}",
            params.proxy_vertices
        )));
    }
    if let Units::File { length } = params.units
        && !(length.is_finite() && length > 0.0)
    {
        return Err(DescribeError::Params(format!(
            "the length unit must be positive, got {length}"
        )));
    }
    Ok(())
}

/// The parts of the prepared `surface` under `params` (see the crate documentation, *Parts*), their
/// descriptors, layout and the surface sample; fronts come from (and go to) `fronts`.
fn describe_parts(
    surface: &Surface,
    boundary: &[bool],
    det: &Detection,
    params: &DescribeParams,
    fronts: &Fronts,
) -> Result<ShapeDescription, DescribeError> {
    let total: f64 = surface.areas.iter().sum();
    let whole_level = whole_level(params);
    let parts = choose_parts(surface, boundary, det, params, fronts)?;

    // every front the parts need, in parallel, each as far as its farthest use: what each part
    // reads below then does not depend on the order the fronts ran in
    let mut reach: HashMap<u32, f64> = HashMap::new();
    for p in &parts {
        let r = reach.entry(p.center).or_insert(p.reach);
        *r = r.max(p.reach);
    }
    let mut needed: Vec<(u32, f64)> = reach.into_iter().collect();
    needed.sort_by_key(|&(c, _)| c);
    needed
        .par_iter()
        .map(|&(c, r)| fronts.get(c, r).map(|_| ()))
        .collect::<Result<(), _>>()?;

    let m = parts.len();
    let centers: Vec<u32> = parts.iter().map(|p| p.center).collect();
    // per part: its layout row, whether its front covered its whole piece (+∞ then means
    // another piece), and its description
    let described: Vec<(Vec<f32>, bool, ComponentDescription)> = parts
        .into_par_iter()
        .map(|p| {
            let front = fronts.get(p.center, p.reach)?;
            let d = &front.d;
            let row: Vec<f32> = centers.iter().map(|&o| d[o as usize] as f32).collect();
            let (descriptor, radius, area) = describe_part(surface, &p, d);
            let at = surface.mesh.positions[p.center as usize];
            Ok((
                row,
                front.complete,
                ComponentDescription {
                    descriptor,
                    center: p.center,
                    position: [at.x as f32, at.y as f32, at.z as f32],
                    area: if total > 0.0 { area / total } else { 0.0 },
                    keypoints: p.keypoints,
                    radius,
                    level: p.level,
                    vertices: p.vertices,
                },
            ))
        })
        .collect::<Result<_, DescribeError>>()?;
    let mut layout = Vec::with_capacity(m * m);
    let mut complete = Vec::with_capacity(m);
    let mut components = Vec::with_capacity(m);
    for (row, c, desc) in described {
        layout.extend(row);
        complete.push(c);
        components.push(desc);
    }
    symmetrise(&mut layout, &complete, &components, params, whole_level);
    let sample = surface_sample(&surface.mesh);
    Ok(ShapeDescription {
        components,
        layout,
        sample,
        boundary_vertices: boundary.iter().filter(|&&b| b).count(),
    })
}

/// Symmetrises the `m × m` layout rows of the parts `components` (`complete[i]`: whether part
/// i's front covered its whole piece); disconnected pairs get twice the largest finite
/// distance, pairs beyond the reach of both fronts and pairs with the whole surface (level
/// `whole_level`) [`NO_DISTANCE`].
fn symmetrise(
    layout: &mut [f32],
    complete: &[bool],
    components: &[ComponentDescription],
    params: &DescribeParams,
    whole_level: u8,
) {
    let m = components.len();
    // symmetrise the layout; disconnected pairs get twice the largest finite distance, pairs
    // beyond the reach of both fronts none
    let finite_max = layout
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(0f32, f32::max);
    for i in 0..m {
        for j in 0..i {
            let (a, b) = (layout[i * m + j], layout[j * m + i]);
            let v = if params.whole
                && (components[i].level == whole_level || components[j].level == whole_level)
            {
                NO_DISTANCE
            } else if a.is_finite() && b.is_finite() {
                0.5 * (a + b)
            } else if a.is_finite() || b.is_finite() {
                a.min(b)
            } else if complete[i] || complete[j] {
                2.0 * finite_max
            } else {
                NO_DISTANCE
            };
            layout[i * m + j] = v;
            layout[j * m + i] = v;
        }
        layout[i * m + i] = 0.0;
    }
}

/// [`SAMPLE_POINTS`] points uniform by area on `mesh` (ChaCha8 seeded with [`SAMPLE_SEED`]: the
/// same mesh gives the same points); none when the mesh has no area.
fn surface_sample(mesh: &Mesh) -> Vec<[f32; 3]> {
    let Some(sampler) = keycomp_mesh::sample::AreaSampler::new(mesh) else {
        return Vec::new();
    };
    let mut rng = ChaCha8Rng::seed_from_u64(SAMPLE_SEED);
    (0..SAMPLE_POINTS)
        .map(|_| {
            let (p, _) = sampler.sample(&mut rng);
            [p.x as f32, p.y as f32, p.z as f32]
        })
        .collect()
}
