//! Python bindings of keycomp (PyO3): read meshes, detect key-components (Sipiran & Bustos
//! 2013), build and query an index, match two meshes. The work runs with the GIL released;
//! errors are Python exceptions carrying keycomp's messages (`OSError` when a file cannot be
//! read or written, `ValueError` for bad data or arguments).

use std::path::PathBuf;

use keycomp_components::{Detection, Preset, detect as detect_components};
use keycomp_core::collection::{self, AddOptions};
use keycomp_core::matching::{MatchParams, check_pose_weight, check_verify_weight, match_analysed};
use keycomp_core::options::DetectOptions;
use keycomp_core::search::{Hit, Searcher};
use keycomp_core::{Analysed, Profile, Role, analyse_as, analyse_mesh_as};
use keycomp_mesh::{Mesh, MeshError, Point3, read_mesh as read_mesh_file};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

/// An error as a Python exception: `OSError` for the operating system's errors, `ValueError`
/// otherwise; the message is keycomp's (it names the file).
fn py_err(e: impl std::fmt::Display, io: bool) -> PyErr {
    if io {
        PyOSError::new_err(e.to_string())
    } else {
        PyValueError::new_err(e.to_string())
    }
}

fn mesh_err(e: MeshError) -> PyErr {
    let io = matches!(e.kind, keycomp_mesh::ErrorKind::Io(_));
    py_err(e, io)
}

fn analysis_err(e: keycomp_core::Error) -> PyErr {
    match e {
        keycomp_core::Error::Mesh(m) => mesh_err(m),
        keycomp_core::Error::Index(i) => index_err(i),
        keycomp_core::Error::Path { .. } => py_err(e, true),
        other => py_err(other, false),
    }
}

fn index_err(e: keycomp_index::IndexError) -> PyErr {
    let io = matches!(e, keycomp_index::IndexError::Io { .. });
    py_err(e, io)
}

/// Vertices (n, 3) and faces (m, 3) as numpy arrays.
type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// Reads a mesh file (OFF, OBJ, PLY, STL, glTF/GLB) into `(vertices, faces)`: float64 (n, 3)
/// and int64 (m, 3) arrays, vertex ids as `keycomp detect` numbers them.
#[pyfunction]
fn read_mesh<'py>(py: Python<'py>, path: PathBuf) -> PyResult<MeshArrays<'py>> {
    let mesh = py.detach(|| read_mesh_file(&path)).map_err(mesh_err)?.mesh;
    Ok(arrays(py, &mesh))
}

fn arrays<'py>(py: Python<'py>, mesh: &Mesh) -> MeshArrays<'py> {
    let v: Vec<f64> = mesh
        .positions
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    let f: Vec<i64> = mesh.faces.iter().flat_map(|t| t.map(i64::from)).collect();
    let v = v
        .into_pyarray(py)
        .reshape([mesh.positions.len(), 3])
        .expect("n×3 values");
    let f = f
        .into_pyarray(py)
        .reshape([mesh.faces.len(), 3])
        .expect("m×3 values");
    (v, f)
}

/// A mesh from Python: a path (str or os.PathLike), a `(vertices, faces)` pair of arrays, or
/// an object with `.vertices` and `.faces` (a trimesh.Trimesh).
enum MeshInput {
    Path(PathBuf),
    Mesh(Mesh),
}

fn mesh_from_arrays(vertices: &Bound<'_, PyAny>, faces: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    let np = vertices.py().import("numpy")?;
    let v = np.call_method1("asarray", (vertices, "float64"))?;
    let f = np.call_method1("asarray", (faces, "int64"))?;
    let v: PyReadonlyArray2<f64> = v
        .extract()
        .map_err(|_| PyValueError::new_err("vertices must be an (n, 3) array of numbers"))?;
    let f: PyReadonlyArray2<i64> = f
        .extract()
        .map_err(|_| PyValueError::new_err("faces must be an (m, 3) array of vertex ids"))?;
    let (v, f) = (v.as_array(), f.as_array());
    if v.ncols() != 3 || f.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "vertices must be (n, 3) and faces (m, 3); got {:?} and {:?}",
            v.shape(),
            f.shape()
        )));
    }
    let positions: Vec<Point3<f64>> = v
        .rows()
        .into_iter()
        .map(|r| Point3::new(r[0], r[1], r[2]))
        .collect();
    let mut tris = Vec::with_capacity(f.nrows());
    for (i, r) in f.rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for k in 0..3 {
            t[k] = u32::try_from(r[k])
                .ok()
                .filter(|&x| (x as usize) < positions.len())
                .ok_or_else(|| {
                    PyValueError::new_err(format!(
                        "face {i} refers to vertex {}, there are {}",
                        r[k],
                        positions.len()
                    ))
                })?;
        }
        tris.push(t);
    }
    Ok(Mesh::from_raw(positions, tris).map_err(mesh_err)?.0)
}

fn mesh_input(obj: &Bound<'_, PyAny>, faces: Option<&Bound<'_, PyAny>>) -> PyResult<MeshInput> {
    if let Some(f) = faces {
        return Ok(MeshInput::Mesh(mesh_from_arrays(obj, f)?));
    }
    if let Ok(p) = obj.extract::<PathBuf>() {
        return Ok(MeshInput::Path(p));
    }
    if obj.hasattr("vertices")? && obj.hasattr("faces")? {
        return Ok(MeshInput::Mesh(mesh_from_arrays(
            &obj.getattr("vertices")?,
            &obj.getattr("faces")?,
        )?));
    }
    if let Ok((v, f)) = obj.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>)>() {
        return Ok(MeshInput::Mesh(mesh_from_arrays(&v, &f)?));
    }
    Err(PyValueError::new_err(
        "expected a mesh: a path, (vertices, faces) arrays, or an object with .vertices and .faces",
    ))
}

impl MeshInput {
    fn load(self) -> PyResult<(Mesh, String)> {
        match self {
            MeshInput::Path(p) => Ok((
                read_mesh_file(&p).map_err(mesh_err)?.mesh,
                p.display().to_string(),
            )),
            MeshInput::Mesh(m) => Ok((m, "<array>".to_string())),
        }
    }
}

/// One key-component.
#[pyclass(module = "keycomp", frozen)]
struct Component {
    #[pyo3(get)]
    id: usize,
    #[pyo3(get)]
    center: u32,
    #[pyo3(get)]
    area: f64,
    vertices: Vec<u32>,
    faces: Vec<u32>,
    keypoints: Vec<u32>,
}

#[pymethods]
impl Component {
    /// Vertex ids of the component.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ids(py, &self.vertices)
    }
    /// Face indices of the component.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ids(py, &self.faces)
    }
    /// Keypoints (vertex ids) in the component.
    #[getter]
    fn keypoints<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ids(py, &self.keypoints)
    }
    fn __repr__(&self) -> String {
        format!(
            "Component(id={}, center={}, {} vertices, area={})",
            self.id,
            self.center,
            self.vertices.len(),
            self.area
        )
    }
}

fn ids<'py>(py: Python<'py>, v: &[u32]) -> Bound<'py, PyArray1<i64>> {
    v.iter()
        .map(|&x| i64::from(x))
        .collect::<Vec<_>>()
        .into_pyarray(py)
}

/// The result of `detect`.
#[pyclass(module = "keycomp", frozen)]
struct DetectionResult {
    json: String,
    keypoints: Vec<u32>,
    components: Vec<Py<Component>>,
    mesh: Mesh,
}

#[pymethods]
impl DetectionResult {
    /// Vertex positions (n, 3) of the mesh detection ran on (the canonical surface, or the
    /// mesh as given): the ids of the keypoints and components are its.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays(py, &self.mesh).0
    }
    /// Its triangles (m, 3).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        arrays(py, &self.mesh).1
    }
    /// Keypoints (vertex ids), best first: the ids of `keycomp detect --json`.
    #[getter]
    fn keypoints<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ids(py, &self.keypoints)
    }
    /// The key-components.
    #[getter]
    fn components(&self, py: Python<'_>) -> Vec<Py<Component>> {
        self.components.iter().map(|c| c.clone_ref(py)).collect()
    }
    /// The detection as `keycomp detect --json` prints it, without `timings_ms`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (&self.json,))
    }
    fn __repr__(&self) -> String {
        format!(
            "Detection({} keypoints, {} components)",
            self.keypoints.len(),
            self.components.len()
        )
    }
}

/// Detects key-components (Sipiran & Bustos 2013) with the parameters of `keycomp detect`:
/// a preset ("robust", the default, or the paper's "kc1", "kc2", "kc3"), then the options
/// given on top, on the canonical surface (`surface="canonical"`; ids are its vertices,
/// `DetectionResult.vertices` and `.faces`) or on the mesh as given (`surface="as-read"`).
/// Unless told, as `keycomp detect`: the canonical surface with the robust preset, the mesh as
/// given with the paper's.
#[pyfunction]
#[pyo3(signature = (mesh, faces=None, *, preset="robust", surface=None, density=None, fraction=None, count=None, r=None, t=None, n=None, sigma=None, seed=None))]
#[allow(clippy::too_many_arguments)]
fn detect(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    faces: Option<&Bound<'_, PyAny>>,
    preset: &str,
    surface: Option<&str>,
    density: Option<f64>,
    fraction: Option<f64>,
    count: Option<usize>,
    r: Option<f64>,
    t: Option<f64>,
    n: Option<usize>,
    sigma: Option<f64>,
    seed: Option<u64>,
) -> PyResult<DetectionResult> {
    let preset: Preset = preset.parse().map_err(|_| {
        PyValueError::new_err(format!(
            "unknown preset '{preset}' (robust, kc1, kc2 or kc3)"
        ))
    })?;
    let surface = surface_choice(surface)?;
    let options = DetectOptions {
        preset,
        density,
        fraction,
        count,
        r,
        t,
        n,
        sigma,
        seed,
        ..Default::default()
    };
    let canonical = surface.unwrap_or_else(|| options.canonical_by_default());
    let input = mesh_input(mesh, faces)?;
    let (json, det, analysed): (String, Detection, Mesh) = py.detach(|| -> PyResult<_> {
        let (mesh, name) = input.load()?;
        let mut params = options.params();
        let mesh = if canonical {
            // as `keycomp detect`: no keypoints from fits that reach a border
            params.harris.skip_boundary = true;
            keycomp_core::analysis::canonical_surface(
                &keycomp_mesh::Geometry::Mesh(mesh),
                &Default::default(),
            )
            .map_err(|e| py_err(format!("{name}: no canonical surface: {e}"), false))?
            .mesh
        } else {
            mesh
        };
        let det = detect_components(&mesh, &params).map_err(|e| {
            py_err(
                format!("{name}: key-component detection failed: {e}"),
                false,
            )
        })?;
        let json =
            keycomp_core::json::DetectionJson::<()>::new(&name, &mesh, &det, &params, preset, "kc");
        let json = serde_json::to_string(&json).map_err(|e| py_err(e, false))?;
        Ok((json, det, mesh))
    })?;
    let components = det
        .components
        .iter()
        .map(|c| {
            Py::new(
                py,
                Component {
                    id: c.id,
                    center: c.center,
                    area: c.area,
                    vertices: c.vertices.clone(),
                    faces: c.faces.clone(),
                    keypoints: c.keypoints.clone(),
                },
            )
        })
        .collect::<PyResult<_>>()?;
    Ok(DetectionResult {
        json,
        keypoints: det.keypoints,
        components,
        mesh: analysed,
    })
}

/// One matched pair of parts.
#[pyclass(module = "keycomp", frozen, get_all)]
#[derive(Clone)]
struct Match {
    query_component: usize,
    target_component: usize,
    distance: f32,
}

#[pymethods]
impl Match {
    fn __repr__(&self) -> String {
        format!(
            "Match({} -> {}, distance={})",
            self.query_component, self.target_component, self.distance
        )
    }
}

fn matches_of(hit: &Hit) -> Vec<Match> {
    hit.matches
        .iter()
        .map(|c| Match {
            query_component: c.query_component,
            target_component: c.target_component,
            distance: c.distance,
        })
        .collect()
}

/// One shape returned by `Index.query`.
#[pyclass(module = "keycomp", frozen, get_all)]
struct QueryResult {
    path: String,
    score: f64,
    matches: Vec<Match>,
    transform: Option<Transform>,
}

#[pymethods]
impl QueryResult {
    fn __repr__(&self) -> String {
        format!(
            "QueryResult({:?}, score={:.4}, {} matches)",
            self.path,
            self.score,
            self.matches.len()
        )
    }
}

/// Where a query sits on a shape: the similarity transform from the query's file coordinates
/// to the shape's, `p' = scale·rotation·p + translation` (column vectors; `rotation` and the
/// 4×4 `matrix` row-major), as `keycomp query --json` and `keycomp match --json` give it.
#[pyclass(module = "keycomp", frozen, get_all)]
#[derive(Clone)]
struct Transform {
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
    scale: f64,
    matrix: [[f64; 4]; 4],
    verified: f64,
    rms: Option<f64>,
}

#[pymethods]
impl Transform {
    fn __repr__(&self) -> String {
        format!(
            "Transform(scale={:.4}, translation={:?}, verified={:.3})",
            self.scale, self.translation, self.verified
        )
    }
}

impl From<&keycomp_core::transform::Transform> for Transform {
    fn from(t: &keycomp_core::transform::Transform) -> Self {
        Transform {
            rotation: t.rotation,
            translation: t.translation,
            scale: t.scale,
            matrix: t.matrix,
            verified: t.verified,
            rms: t.rms,
        }
    }
}

/// The result of `match(a, b)`: the score of A's parts matched in B, in [0, 1].
#[pyclass(module = "keycomp", frozen, get_all)]
struct MatchResult {
    score: f64,
    matches: Vec<Match>,
    rejected: usize,
    scale: Option<f64>,
    pose: Option<f64>,
    verified: Option<f64>,
    transform: Option<Transform>,
}

#[pymethods]
impl MatchResult {
    fn __repr__(&self) -> String {
        format!(
            "MatchResult(score={:.4}, {} matches)",
            self.score,
            self.matches.len()
        )
    }
}

fn analyse_input(input: MeshInput, profile: &Profile, role: Role) -> PyResult<Analysed> {
    match input {
        MeshInput::Path(p) => analyse_as(&p, profile, role).map_err(analysis_err),
        MeshInput::Mesh(m) => analyse_mesh_as(m, profile, role).map_err(analysis_err),
    }
}

/// The surface a caller asks for: `"as-read"` (`Some(false)`), `"canonical"` (`Some(true)`), or
/// nothing (`None`).
fn surface_choice(surface: Option<&str>) -> PyResult<Option<bool>> {
    match surface {
        None => Ok(None),
        Some("as-read") => Ok(Some(false)),
        Some("canonical") => Ok(Some(true)),
        Some(other) => Err(PyValueError::new_err(format!(
            "surface must be 'as-read' or 'canonical', got '{other}'"
        ))),
    }
}

/// Matches two meshes part to part, as `keycomp match A B`; `pose` weighs the pose check as
/// `keycomp match --pose` does (0–1, default 0), `verify` geometric verification as
/// `keycomp match --verify` does (0–1, or None, the default: automatic), `surface` is
/// `keycomp match --surface`: "canonical" (the default: both sides remade as their canonical
/// surface) or "as-read" (the meshes as given; point clouds still get their canonical surface).
#[pyfunction(name = "match", signature = (a, b, pose=0.0, verify=None, surface=None))]
fn match_meshes(
    py: Python<'_>,
    a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
    pose: f64,
    verify: Option<f64>,
    surface: Option<&str>,
) -> PyResult<MatchResult> {
    let pose = check_pose_weight(pose).map_err(analysis_err)?;
    let verify = check_verify_weight(verify).map_err(analysis_err)?;
    let canonical = surface_choice(surface)?.unwrap_or(true);
    let (a, b) = (mesh_input(a, None)?, mesh_input(b, None)?);
    py.detach(|| {
        let profile = Profile::current(&DetectOptions::default().retrieval_params())
            .with_surface(canonical.then(Default::default));
        let (a, b) = rayon::join(
            || analyse_input(a, &profile, Role::Query),
            || analyse_input(b, &profile, Role::Indexed),
        );
        let (a, b) = (a?, b?);
        let params = MatchParams {
            pose_weight: pose,
            verify_weight: a.verify_weight(verify),
            ..MatchParams::default()
        };
        let m = match_analysed(&a, &b, ("a", "b"), &params);
        Ok(MatchResult {
            score: m.score,
            matches: m
                .matches
                .iter()
                .map(|p| Match {
                    query_component: p.a_component,
                    target_component: p.b_component,
                    distance: p.distance,
                })
                .collect(),
            rejected: m.rejected,
            scale: m.scale,
            pose: m.pose,
            transform: m.transform.as_ref().map(Transform::from),
            verified: m.verified,
        })
    })
}

/// An on-disk keycomp index (the format of `keycomp index`). Opening creates nothing: the
/// folder is made by the first `add`.
#[pyclass(module = "keycomp")]
struct Index {
    path: PathBuf,
}

#[pymethods]
impl Index {
    #[new]
    fn new(path: PathBuf) -> Self {
        Index { path }
    }

    /// The index folder.
    #[getter]
    fn path(&self) -> String {
        self.path.display().to_string()
    }

    /// Adds meshes: paths of files (meshes, range scans, point clouds; folders are searched
    /// recursively) or `(name, vertices, faces)` tuples of meshes in memory, stored under
    /// `name`. Files and meshes already indexed with the same content are skipped. Returns the
    /// number of shapes added or replaced. A mesh that cannot be analysed raises, and nothing
    /// of the call is stored. `surface` is `keycomp index add --surface`: "canonical" or
    /// "as-read", recorded by a new index (default "canonical"); another than the index's
    /// raises.
    #[pyo3(signature = (items, surface=None))]
    fn add(
        &self,
        py: Python<'_>,
        items: Vec<Bound<'_, PyAny>>,
        surface: Option<&str>,
    ) -> PyResult<usize> {
        let options = AddOptions {
            canonical: surface_choice(surface)?,
            ..AddOptions::default()
        };
        let mut paths = Vec::new();
        let mut meshes = Vec::new();
        for item in &items {
            if let Ok(p) = item.extract::<PathBuf>() {
                paths.push(p);
            } else if let Ok((name, v, f)) =
                item.extract::<(PathBuf, Bound<'_, PyAny>, Bound<'_, PyAny>)>()
            {
                meshes.push((name, mesh_from_arrays(&v, &f)?));
            } else {
                return Err(PyValueError::new_err(
                    "Index.add takes paths, or (name, vertices, faces) tuples",
                ));
            }
        }
        py.detach(|| {
            let files = keycomp_core::mesh_files(&paths).map_err(analysis_err)?;
            let s = collection::add_items(&self.path, &files, meshes, &options, &())
                .map_err(analysis_err)?;
            Ok(s.added + s.replaced)
        })
    }

    /// Adds mesh files and every mesh below folders as `keycomp index add` does: a file that
    /// cannot be analysed is listed and the others stored, in commits of 32 shapes. Returns
    /// `{"added", "replaced", "unchanged", "failed": [{"path", "message"}], "shapes"}`;
    /// `surface` as for `add`.
    #[pyo3(signature = (paths, surface=None))]
    fn add_files<'py>(
        &self,
        py: Python<'py>,
        paths: Vec<PathBuf>,
        surface: Option<&str>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let canonical = surface_choice(surface)?;
        let summary = py.detach(|| {
            let options = AddOptions {
                keep_going: true,
                canonical,
                ..AddOptions::default()
            };
            collection::add(&self.path, &paths, &options, &()).map_err(analysis_err)
        })?;
        let text = serde_json::to_string(&summary).map_err(|e| py_err(e, false))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Merges other indexes (built apart, e.g. shards) into this one in one commit, as
    /// `keycomp index merge`; returns the number of shapes added.
    fn merge(&self, py: Python<'_>, sources: Vec<PathBuf>) -> PyResult<usize> {
        py.detach(|| {
            Ok(collection::merge(&self.path, &sources)
                .map_err(analysis_err)?
                .added)
        })
    }

    /// Removes shapes by path (a folder: every indexed shape under it); returns how many were
    /// removed.
    fn remove(&self, py: Python<'_>, paths: Vec<PathBuf>) -> PyResult<usize> {
        py.detach(|| {
            Ok(collection::remove(&self.path, &paths)
                .map_err(analysis_err)?
                .removed)
        })
    }

    /// The `k` best shapes for a mesh (a path, (vertices, faces), or a trimesh), best first;
    /// `pose` weighs the pose check as `keycomp query --pose` does (0–1, default 0), `verify`
    /// geometric verification as `keycomp query --verify` does (0–1, or None, the default:
    /// automatic).
    #[pyo3(signature = (mesh, k=10, pose=0.0, verify=None))]
    fn query(
        &self,
        py: Python<'_>,
        mesh: &Bound<'_, PyAny>,
        k: usize,
        pose: f64,
        verify: Option<f64>,
    ) -> PyResult<Vec<QueryResult>> {
        if k == 0 {
            return Err(PyValueError::new_err("k must be at least 1"));
        }
        let input = mesh_input(mesh, None)?;
        py.detach(|| {
            let mut searcher = Searcher::open(&self.path, None).map_err(analysis_err)?;
            searcher.set_pose_weight(pose).map_err(analysis_err)?;
            searcher.set_verify_weight(verify).map_err(analysis_err)?;
            let answer = match input {
                MeshInput::Path(p) => searcher.query(&p, k),
                MeshInput::Mesh(m) => searcher.query_mesh("query", m, k),
            }
            .map_err(analysis_err)?;
            Ok(answer
                .results
                .iter()
                .map(|h| QueryResult {
                    path: h.path.clone(),
                    score: h.score,
                    matches: matches_of(h),
                    transform: h.transform.as_ref().map(Transform::from),
                })
                .collect())
        })
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        py.detach(|| {
            if !self.path.join(keycomp_index::MANIFEST_NAME).is_file() {
                return Ok(0);
            }
            Ok(collection::Reader::open_mapped(&self.path)
                .map_err(index_err)?
                .len())
        })
    }

    fn __repr__(&self) -> String {
        format!("Index({:?})", self.path.display().to_string())
    }
}

/// The mesh files among `paths` and below its folders, as `keycomp index add` lists them:
/// folders searched recursively for supported extensions, each folder's files sorted.
#[pyfunction]
fn mesh_files(py: Python<'_>, paths: Vec<PathBuf>) -> PyResult<Vec<String>> {
    let files = py
        .detach(|| keycomp_core::mesh_files(&paths))
        .map_err(analysis_err)?;
    Ok(files.iter().map(|p| p.display().to_string()).collect())
}

/// keycomp: key-components of 3D meshes for matching and partial retrieval.
#[pymodule]
fn _keycomp(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(detect, m)?)?;
    m.add_function(wrap_pyfunction!(match_meshes, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_files, m)?)?;
    m.add_class::<Index>()?;
    m.add_class::<DetectionResult>()?;
    m.add_class::<Component>()?;
    m.add_class::<QueryResult>()?;
    m.add_class::<MatchResult>()?;
    m.add_class::<Transform>()?;
    m.add_class::<Match>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
