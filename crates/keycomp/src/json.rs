//! The JSON of a detection, as `keycomp detect --json` prints it (and the Python package's
//! `Detection.to_dict()` returns, without timings).

use keycomp_components::{DetectParams, Detection, Preset};
use keycomp_mesh::Mesh;
use keycomp_mser::MserParams;
use serde::Serialize;

/// A component's smallest enclosing sphere of its keypoints.
#[derive(Debug, Serialize)]
pub struct SphereJson {
    /// Centre, in mesh coordinates.
    pub center: [f64; 3],
    /// Radius, in mesh units.
    pub radius: f64,
}

/// One key-component.
#[derive(Debug, Serialize)]
pub struct ComponentJson<'a> {
    /// Its index in the detection.
    pub id: usize,
    /// The vertex at its geodesic centre.
    pub center: u32,
    /// The enclosing sphere of its keypoints.
    pub sphere: SphereJson,
    /// Its keypoints (vertex ids).
    pub keypoints: &'a [u32],
    /// Its vertices.
    pub vertices: &'a [u32],
    /// Its faces (indices into the mesh's faces).
    pub faces: &'a [u32],
    /// Its area as a fraction of the mesh's total area (in [0, 1]).
    pub area: f64,
}

/// A whole detection: the mesh's counts and area, the parameters, the keypoints best first and
/// the components; `timings_ms` of type `T` is left out when `None`.
#[derive(Debug, Serialize)]
pub struct DetectionJson<'a, T: Serialize> {
    /// The mesh's name (its path for a file).
    pub mesh: String,
    /// Vertex count.
    pub vertices: usize,
    /// Face count.
    pub faces: usize,
    /// Surface area, in mesh units squared.
    pub area: f64,
    /// The preset the parameters started from.
    pub preset: String,
    /// `kc`, `mser` or `mser-kc`.
    pub method: &'static str,
    /// Every detection parameter.
    pub params: &'a DetectParams,
    /// MSER parameters, for the MSER methods.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mser_params: Option<MserParams>,
    /// Keypoints (vertex ids), best first.
    pub keypoints: &'a [u32],
    /// The key-components.
    pub components: Vec<ComponentJson<'a>>,
    /// Stage timings, when measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timings_ms: Option<T>,
}

impl<'a, T: Serialize> DetectionJson<'a, T> {
    /// The JSON of `det` on `mesh` (named `name`), found with `params` from `preset` by
    /// `method`; no MSER parameters and no timings (set them after).
    pub fn new(
        name: &str,
        mesh: &Mesh,
        det: &'a Detection,
        params: &'a DetectParams,
        preset: Preset,
        method: &'static str,
    ) -> Self {
        DetectionJson {
            mesh: name.to_string(),
            vertices: mesh.num_vertices(),
            faces: mesh.num_faces(),
            area: det.area,
            preset: preset.to_string(),
            method,
            params,
            mser_params: None,
            keypoints: &det.keypoints,
            components: det
                .components
                .iter()
                .map(|c| ComponentJson {
                    id: c.id,
                    center: c.center,
                    sphere: SphereJson {
                        center: c.sphere_center,
                        radius: c.sphere_radius,
                    },
                    keypoints: &c.keypoints,
                    vertices: &c.vertices,
                    faces: &c.faces,
                    area: c.area,
                })
                .collect(),
            timings_ms: None,
        }
    }
}
