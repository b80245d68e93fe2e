//! Analysing a mesh for matching and retrieval: read it (a mesh, a range scan or a point
//! cloud), detect its key-components, describe its parts, under a [`Profile`] (the parameters
//! an index records so that its descriptors stay comparable).
//!
//! What is analysed is the mesh as read, or, when the profile asks for it
//! ([`Profile::surface`]), its canonical surface (`keycomp_surface`: one connected surface of a
//! fixed density relative to its size, for a mesh at any resolution, a triangle soup, a range
//! scan or a point cloud alike). A point cloud has no mesh to analyse: it is always analysed on
//! its canonical surface.

use std::path::{Path, PathBuf};
use std::time::Instant;

use keycomp_components::{DetectError, DetectParams, Detection, detect, detect_in};
use keycomp_describe::{DIM, DescribeError, DescribeParams, ShapeDescription, describe_all};
use keycomp_harris::UnitArea;
use keycomp_index::{ComponentRecord, ContentHash, ShapeRecord, canonical_path};
use keycomp_mesh::{Format, Geometry, Mesh, MeshError, Topology, read_input};
use keycomp_surface::{SurfaceError, SurfaceParams};
use rayon::prelude::*;

/// What can go wrong while analysing a mesh. Every variant that concerns a file names it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read, or is not a valid mesh.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// Key-component detection failed (invalid parameters, or the mesh has no usable area).
    #[error("{}: key-component detection failed: {source}", show(path))]
    Detection {
        /// The mesh file, if the mesh came from one.
        path: Option<PathBuf>,
        /// Why.
        source: DetectError,
    },
    /// No canonical surface could be made (the input has no area).
    #[error("{}: {source}", show(path))]
    Surface {
        /// The mesh file, if the mesh came from one.
        path: Option<PathBuf>,
        /// Why.
        source: SurfaceError,
    },
    /// Describing the parts failed.
    #[error("{}: describing its parts failed: {source}", show(path))]
    Description {
        /// The mesh file, if the mesh came from one.
        path: Option<PathBuf>,
        /// Why.
        source: DescribeError,
    },
    /// The profile could not be written as JSON.
    #[error("cannot write the profile: {0}")]
    Profile(#[from] serde_json::Error),
    /// An option or argument is invalid (a unit length that is not positive, no mesh file in
    /// the paths given, …).
    #[error("{0}")]
    Invalid(String),
    /// An index's descriptors cannot be compared with a query's (see [`query_profile`]).
    #[error("{0}")]
    Incomparable(String),
    /// An index or file operation failed.
    #[error(transparent)]
    Index(#[from] keycomp_index::IndexError),
    /// A path named is neither a file nor a folder, or a folder cannot be listed.
    #[error("{}: {reason}", path.display())]
    Path {
        /// The path.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// An error and its causes on one line, `outer: inner: …`, leaving out a cause whose text the
/// line already holds (an error that shows its source in its own message and also returns it as
/// its source would otherwise say it twice: "No such file (os error 2): No such file (os
/// error 2)").
pub fn error_line(e: &(dyn std::error::Error + 'static)) -> String {
    let mut line = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let text = s.to_string();
        if !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
        source = s.source();
    }
    line
}

fn show(path: &Option<PathBuf>) -> String {
    path.as_ref()
        .map_or_else(|| "the mesh".to_string(), |p| p.display().to_string())
}

/// The profile recorded in an index (`keycomp_index::IndexWriter::ensure_profile`): what makes
/// its descriptors comparable — descriptor version, the canonical surface, description and
/// detection parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Profile {
    /// [`keycomp_describe::DESCRIPTOR_VERSION`].
    pub descriptor_version: u32,
    /// How inputs are measured ([`Profile::VERSION`] for profiles this keycomp makes):
    /// - 1 (profiles recorded before the field existed): every input scaled to its own unit
    ///   area, a canonical surface of a fixed vertex count whatever the input stands for, a
    ///   fragment's scale hypotheses as larger patch radii;
    /// - 2: every input measured in the unit of the shape it stands for (a whole shape its own
    ///   area, a fragment under each scale hypothesis the area of the source it implies, in
    ///   file units the collection's unit), its canonical surface sampled at one density per
    ///   unit of that area, detection (`keycomp_components::detect_in`) and description in that
    ///   unit.
    #[serde(default = "first_version")]
    pub version: u32,
    /// The canonical surface every input is analysed on; `None`: meshes as read (point clouds
    /// on a canonical surface of default parameters). Profiles written before it existed read
    /// as `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceParams>,
    /// Description parameters.
    pub describe: DescribeParams,
    /// Detection parameters.
    pub detect: DetectParams,
}

fn first_version() -> u32 {
    1
}

impl Profile {
    /// The profile version this keycomp records ([`Profile::version`]).
    pub const VERSION: u32 = 2;

    /// The profile of descriptors this keycomp makes with `params` and the default description,
    /// on the default canonical surface.
    pub fn current(params: &DetectParams) -> Profile {
        Profile::with(params, DescribeParams::default())
    }

    /// The profile of descriptors this keycomp makes with `params` and `describe`, on the
    /// default canonical surface ([`Profile::with_surface`] changes it).
    pub fn with(params: &DetectParams, describe: DescribeParams) -> Profile {
        Profile {
            descriptor_version: keycomp_describe::DESCRIPTOR_VERSION,
            version: Self::VERSION,
            surface: None,
            describe,
            detect: params.clone(),
        }
        .with_surface(Some(SurfaceParams::default()))
    }

    /// Whether inputs are measured in the unit of the shape they stand for (version 2 and
    /// later, [`Profile::version`]).
    pub fn in_source_units(&self) -> bool {
        self.version >= 2
    }

    /// For an index recorded with an older profile version (`dir` its folder): what it keeps
    /// doing and how to move it to this keycomp's analysis; `None` for a current profile.
    pub fn migration_note(&self, dir: &Path) -> Option<String> {
        (self.version < Self::VERSION).then(|| {
            format!(
                "index {} was built by an earlier keycomp (profile version {}: every input at its \
                 own unit area, {}); it keeps answering as it was built, but this keycomp \
                 measures new indexes in the unit of the shape each input stands for, on \
                 canonical surfaces sampled at one density (profile version {}): to move to \
                 it, build a new index from the same files (`keycomp index add FILES --index \
                 NEW`, or delete the folder first)",
                dir.display(),
                self.version,
                self.surface_name(),
                Self::VERSION
            )
        })
    }

    /// What the profile analyses, in words: "canonical surfaces" or "meshes as read".
    pub fn surface_name(&self) -> &'static str {
        if self.surface.is_some() {
            "canonical surfaces"
        } else {
            "meshes as read"
        }
    }

    /// This profile with inputs analysed on their canonical surface of `surface` (`None`: as
    /// read). On a canonical surface the only boundaries are real ones (a scan's or a
    /// fragment's border), and Harris fits that reach them are left out of detection and of
    /// the descriptors (`HarrisParams::skip_boundary`).
    pub fn with_surface(mut self, surface: Option<SurfaceParams>) -> Profile {
        let on = surface.is_some();
        self.surface = surface;
        self.detect.harris.skip_boundary = on;
        self.describe.harris.skip_boundary = on;
        self
    }

    /// As recorded in the index (compact JSON).
    pub fn to_text(&self) -> Result<String, Error> {
        Ok(serde_json::to_string(self)?)
    }
}

/// A mesh read, detected and described.
pub struct Analysed {
    /// What detection and description ran on (their vertex ids are this mesh's): the mesh as
    /// read, or its canonical surface ([`Profile::surface`]).
    pub mesh: Mesh,
    /// What the reader noticed and tolerated (unknown header lines, dropped NaN points, …).
    pub warnings: Vec<String>,
    /// The input as read (the mesh or the points of the file, in its coordinates): where a
    /// pose is refined ([`crate::transform::Transform::refined_best`]) and a canonical surface's
    /// colours are carried back.
    pub input: Geometry,
    /// Its key-components (Sipiran & Bustos 2013).
    pub detection: Detection,
    /// Its parts at several scales, their descriptors and layout (for a query with several
    /// scale hypotheses, those of the first: hypothesis 0).
    pub description: ShapeDescription,
    /// The share of its source's area the input is taken for under hypothesis 0: 1 for a whole
    /// shape ([`FRAGMENT_SHARES`]).
    pub share: f64,
    /// A query's analyses under its other scale hypotheses, hypothesis 1 onwards; empty for
    /// one description.
    pub hypotheses: Vec<Hypothesis>,
    /// Wall time of the analysis (reading included for a file), in milliseconds.
    pub ms: f64,
    /// The length unit it was described in.
    pub units: keycomp_describe::Units,
    /// Whether it was analysed on its canonical surface ([`Profile::surface`]).
    pub canonical: bool,
}

/// A query's analysis under one scale hypothesis ([`Analysed::hypotheses`]).
#[derive(Debug, Clone)]
pub struct Hypothesis {
    /// What detection and description ran on under this hypothesis (profile version 2
    /// samples a canonical surface per hypothesis; version 1 shares one).
    pub mesh: Mesh,
    /// Its key-components.
    pub detection: Detection,
    /// Its parts.
    pub description: ShapeDescription,
    /// The share of its source's area the input is taken for.
    pub share: f64,
}

/// The shares of its source's area a scale-free query with a boundary (a fragment, a scan) is
/// taken for, one analysis each (profile version 2): 44 % and 20 %, one and two steps of 1.5
/// up the patch radii's ladder (`keycomp_describe::FRAGMENT_LEVEL_FACTORS`, which version 1
/// applies to the radii instead).
pub const FRAGMENT_SHARES: [f64; 2] = [
    1.0 / (keycomp_describe::FRAGMENT_LEVEL_FACTORS[0]
        * keycomp_describe::FRAGMENT_LEVEL_FACTORS[0]),
    1.0 / (keycomp_describe::FRAGMENT_LEVEL_FACTORS[1]
        * keycomp_describe::FRAGMENT_LEVEL_FACTORS[1]),
];

/// What a mesh is analysed as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A shape of the collection, described under the profile as it is.
    Indexed,
    /// A query against the collection: a fragment is described with its patch radii adapted
    /// to its size when the scale is free ([`DescribeParams::for_query`]).
    Query,
}

/// Reads, detects and describes one mesh file under `profile`, as a shape of the collection.
pub fn analyse(path: &Path, profile: &Profile) -> Result<Analysed, Error> {
    analyse_as(path, profile, Role::Indexed)
}

/// Reads, detects and describes one mesh file under `profile`, as `role`. Meshes, range
/// scans and point clouds are read (`keycomp_mesh::read_input`).
pub fn analyse_as(path: &Path, profile: &Profile, role: Role) -> Result<Analysed, Error> {
    let t = Instant::now();
    let loaded = read_input(path)?;
    let mut a = analyse_in(loaded.geometry, profile, Some(path), role)?;
    a.warnings.splice(0..0, loaded.warnings);
    a.ms = t.elapsed().as_secs_f64() * 1e3;
    Ok(a)
}

/// Detects and describes a mesh already in memory under `profile`, as a shape of the
/// collection.
pub fn analyse_mesh(mesh: Mesh, profile: &Profile) -> Result<Analysed, Error> {
    analyse_in(Geometry::Mesh(mesh), profile, None, Role::Indexed)
}

/// Detects and describes a mesh already in memory under `profile`, as `role`.
pub fn analyse_mesh_as(mesh: Mesh, profile: &Profile, role: Role) -> Result<Analysed, Error> {
    analyse_in(Geometry::Mesh(mesh), profile, None, role)
}

/// The canonical surface of `geometry` under `params` (`keycomp_surface::canonical`), for a
/// whole shape.
pub fn canonical_surface(
    geometry: &Geometry,
    params: &SurfaceParams,
) -> Result<keycomp_surface::Surface, SurfaceError> {
    canonical_surface_at(geometry, params, keycomp_surface::Density::Share(1.0))
}

/// [`canonical_surface`] sampled at `density`.
pub fn canonical_surface_at(
    geometry: &Geometry,
    params: &SurfaceParams,
    density: keycomp_surface::Density,
) -> Result<keycomp_surface::Surface, SurfaceError> {
    let input = match geometry {
        Geometry::Mesh(mesh) => keycomp_surface::Input::Mesh(mesh),
        Geometry::Points(cloud) => keycomp_surface::Input::Points {
            positions: &cloud.positions,
            normals: cloud.normals.as_deref(),
        },
    };
    keycomp_surface::canonical_at(input, params, density)
}

/// What a point cloud analysed under a profile of meshes as read is told: it gets a canonical
/// surface (it has no mesh), which the profile's other shapes do not.
pub const CLOUD_ON_AS_READ: &str = "a point cloud is analysed on its canonical surface, but \
meshes are analysed as read here (`--surface as-read`, or an index built so): its parts are not \
measured as a mesh's are and may match poorly; analyse every input on its canonical surface \
(the default; an index built with it)";

fn analyse_in(
    geometry: Geometry,
    profile: &Profile,
    path: Option<&Path>,
    role: Role,
) -> Result<Analysed, Error> {
    let mixed = profile.surface.is_none() && matches!(geometry, Geometry::Points(_));
    let mut a = if profile.in_source_units() {
        Measured {
            geometry,
            profile,
            path,
            t: Instant::now(),
        }
        .analyse(role)?
    } else {
        let input = geometry.clone();
        let mut a = analyse_first_version(geometry, profile, path, role)?;
        a.input = input;
        a
    };
    if mixed {
        a.warnings.push(CLOUD_ON_AS_READ.to_string());
    }
    Ok(a)
}

/// The analysis of a version 1 profile ([`Profile::version`]), kept so that indexes built
/// with one answer queries as they were built.
fn analyse_first_version(
    geometry: Geometry,
    profile: &Profile,
    path: Option<&Path>,
    role: Role,
) -> Result<Analysed, Error> {
    let t = Instant::now();
    let mesh = match (geometry, &profile.surface) {
        (Geometry::Mesh(mesh), None) => mesh,
        (geometry, surface) => {
            canonical_surface(&geometry, &surface.unwrap_or_default())
                .map_err(|source| Error::Surface {
                    path: path.map(Path::to_path_buf),
                    source,
                })?
                .mesh
        }
    };
    let detection = detect(&mesh, &profile.detect).map_err(|source| Error::Detection {
        path: path.map(Path::to_path_buf),
        source,
    })?;
    let params = match role {
        Role::Indexed => vec![profile.describe.clone()],
        Role::Query => profile.describe.for_query(&mesh),
    };
    let description_error = |source| Error::Description {
        path: path.map(Path::to_path_buf),
        source,
    };
    // the hypotheses share the smoothed surface, its fits and the fronts
    let mut descriptions = describe_all(&mesh, &detection, &params).map_err(description_error)?;
    if descriptions.is_empty() {
        return Err(description_error(DescribeError::Params(
            "no description parameters".into(),
        )));
    }
    let description = descriptions.remove(0);
    let share = if descriptions.is_empty() {
        1.0
    } else {
        FRAGMENT_SHARES[0]
    };
    let hypotheses = descriptions
        .into_iter()
        .zip(FRAGMENT_SHARES.iter().skip(1))
        .map(|(description, &share)| Hypothesis {
            mesh: mesh.clone(),
            detection: detection.clone(),
            description,
            share,
        })
        .collect();
    Ok(Analysed {
        mesh,
        warnings: Vec::new(),
        input: no_input(),
        detection,
        description,
        share,
        hypotheses,
        ms: t.elapsed().as_secs_f64() * 1e3,
        units: profile.describe.units,
        canonical: profile.surface.is_some(),
    })
}

/// The input of a version 1 analysis before [`analyse_in`] sets it.
fn no_input() -> Geometry {
    Geometry::Points(keycomp_mesh::PointCloud {
        positions: Vec::new(),
        normals: None,
    })
}

/// An input about to be analysed under a version 2 profile: every analysis measured in the
/// unit of the shape the input stands for.
struct Measured<'a> {
    geometry: Geometry,
    profile: &'a Profile,
    path: Option<&'a Path>,
    t: Instant,
}

impl Measured<'_> {
    fn path(&self) -> Option<PathBuf> {
        self.path.map(Path::to_path_buf)
    }

    /// The surface analysed for `share` (the share of the source's area the input is taken
    /// for; in file units the collection's unit sets the density instead): the canonical one
    /// sampled at the profile's density per unit of the source's area, or the mesh as read.
    fn surface(&self, share: f64) -> Result<Mesh, Error> {
        let density = match self.profile.describe.units {
            keycomp_describe::Units::File { length } => {
                keycomp_surface::Density::UnitArea(length * length)
            }
            keycomp_describe::Units::ScaleFree => keycomp_surface::Density::Share(share),
        };
        match (&self.geometry, &self.profile.surface) {
            (Geometry::Mesh(mesh), None) => Ok(mesh.clone()),
            (geometry, surface) => {
                Ok(
                    canonical_surface_at(geometry, &surface.unwrap_or_default(), density)
                        .map_err(|source| Error::Surface {
                            path: self.path(),
                            source,
                        })?
                        .mesh,
                )
            }
        }
    }

    /// Detects and describes `mesh` taken for `share` of its source: in the source's unit
    /// (scale-free: the source's area is the mesh's over `share`; in file units the
    /// collection's unit), its parts' positions, areas, layout and sample then brought back to
    /// the mesh's own unit-area frame, in which matching compares a query with its targets.
    fn hypothesis(&self, mesh: Mesh, share: f64) -> Result<Hypothesis, Error> {
        let area = keycomp_mesh::geometry::total_area(&mesh);
        let unit = match self.profile.describe.units {
            keycomp_describe::Units::File { length } => length * length,
            keycomp_describe::Units::ScaleFree => area / share,
        };
        let detection =
            detect_in(&mesh, &self.profile.detect, UnitArea::Given(unit)).map_err(|source| {
                Error::Detection {
                    path: self.path(),
                    source,
                }
            })?;
        let mut description = describe_all(
            &mesh,
            &detection,
            std::slice::from_ref(&self.profile.describe),
        )
        .map_err(|source| Error::Description {
            path: self.path(),
            source,
        })?
        .pop()
        .ok_or_else(|| Error::Invalid("no description parameters".into()))?;
        if matches!(
            self.profile.describe.units,
            keycomp_describe::Units::ScaleFree
        ) && area > 0.0
        {
            to_own_frame(&mut description, (unit / area).sqrt());
        }
        Ok(Hypothesis {
            mesh,
            detection,
            description,
            share,
        })
    }

    /// The analysis as `role`: one hypothesis for an indexed shape, a closed query or a query
    /// in file units; one per [`FRAGMENT_SHARES`] for a scale-free query with a boundary.
    fn analyse(self, role: Role) -> Result<Analysed, Error> {
        let scale_free = matches!(
            self.profile.describe.units,
            keycomp_describe::Units::ScaleFree
        );
        let mut hypotheses = if role == Role::Query && scale_free && self.may_be_open() {
            let [s0, s1] = FRAGMENT_SHARES;
            // sampled as a fragment first: if that surface has no boundary, the query is whole.
            // A point cloud is nearly always a view: its second surface is sampled beside the
            // first at once; a mesh with a boundary (a soup) often closes, so it waits
            let (first, second) = match &self.geometry {
                Geometry::Points(_) => {
                    let (a, b) = rayon::join(|| self.surface(s0), || self.surface(s1));
                    (a?, Some(b))
                }
                Geometry::Mesh(_) => (self.surface(s0)?, None),
            };
            if Topology::new(&first).boundary_vertices().is_empty() {
                vec![self.hypothesis(self.surface(1.0)?, 1.0)?]
            } else {
                // the hypotheses are independent: analysed side by side
                let (h0, h1) = rayon::join(
                    || self.hypothesis(first, s0),
                    || self.hypothesis(second.unwrap_or_else(|| self.surface(s1))?, s1),
                );
                vec![h0?, h1?]
            }
        } else {
            vec![self.hypothesis(self.surface(1.0)?, 1.0)?]
        };
        let first = hypotheses.remove(0);
        Ok(Analysed {
            mesh: first.mesh,
            warnings: Vec::new(),
            input: self.geometry,
            detection: first.detection,
            description: first.description,
            share: first.share,
            hypotheses,
            ms: self.t.elapsed().as_secs_f64() * 1e3,
            units: self.profile.describe.units,
            canonical: self.profile.surface.is_some(),
        })
    }

    /// Whether the analysed surface may have a boundary: a point cloud, or a mesh with one (a
    /// soup's boundaries may close on its canonical surface; a closed mesh's surface is closed).
    fn may_be_open(&self) -> bool {
        match &self.geometry {
            Geometry::Points(_) => true,
            Geometry::Mesh(mesh) => !Topology::new(mesh).boundary_vertices().is_empty(),
        }
    }
}

/// Brings a description made in its source's unit back to the described mesh's own unit-area
/// frame: lengths times `k` (the source's unit over the mesh's own: `√(unit area / area)`).
/// Areas are already shares of the mesh's own area, and descriptors are scale-free.
fn to_own_frame(d: &mut ShapeDescription, k: f64) {
    if !(k.is_finite() && k > 0.0) || k == 1.0 {
        return;
    }
    let kf = k as f32;
    for c in &mut d.components {
        c.position = c.position.map(|x| x * kf);
        c.radius *= k;
    }
    for x in &mut d.layout {
        if *x != keycomp_describe::NO_DISTANCE {
            *x *= kf;
        }
    }
    for p in &mut d.sample {
        *p = p.map(|x| x * kf);
    }
}

impl Analysed {
    /// Its descriptions: one, or one per scale hypothesis of a query ([`Analysed::hypotheses`]).
    pub fn hypothesis_count(&self) -> usize {
        1 + self.hypotheses.len()
    }

    /// Its description under scale hypothesis `h` (0: [`Analysed::description`]; the first
    /// when there is no such hypothesis).
    pub fn hypothesis(&self, h: usize) -> &ShapeDescription {
        match h {
            0 => &self.description,
            _ => self
                .hypotheses
                .get(h - 1)
                .map_or(&self.description, |x| &x.description),
        }
    }

    /// The mesh analysed under scale hypothesis `h` (the first when there is no such
    /// hypothesis): its vertex ids are those of [`Analysed::hypothesis`]`(h)`'s parts.
    pub fn mesh_of(&self, h: usize) -> &Mesh {
        match h {
            0 => &self.mesh,
            _ => self.hypotheses.get(h - 1).map_or(&self.mesh, |x| &x.mesh),
        }
    }

    /// The detection under scale hypothesis `h` (the first when there is no such hypothesis).
    pub fn detection_of(&self, h: usize) -> &Detection {
        match h {
            0 => &self.detection,
            _ => self
                .hypotheses
                .get(h - 1)
                .map_or(&self.detection, |x| &x.detection),
        }
    }

    /// The share of its source's area the input is taken for under scale hypothesis `h`.
    pub fn share_of(&self, h: usize) -> f64 {
        match h {
            0 => self.share,
            _ => self.hypotheses.get(h - 1).map_or(self.share, |x| x.share),
        }
    }

    /// Makes hypothesis `h` its [`Analysed::description`] (the one a match chose), the
    /// others its [`Analysed::hypotheses`] in their order.
    pub fn select(&mut self, h: usize) {
        if (1..self.hypothesis_count()).contains(&h) {
            let other = &mut self.hypotheses[h - 1];
            std::mem::swap(&mut self.description, &mut other.description);
            std::mem::swap(&mut self.mesh, &mut other.mesh);
            std::mem::swap(&mut self.detection, &mut other.detection);
            std::mem::swap(&mut self.share, &mut other.share);
            self.hypotheses[..h].rotate_right(1);
        }
    }

    /// The matching view of this shape: one descriptor per part, and the parts' layout.
    pub fn view(&self) -> (Vec<keycomp_describe::Descriptor>, &[f32]) {
        self.view_of(0)
    }

    /// [`Analysed::view`] under scale hypothesis `h`.
    pub fn view_of(&self, h: usize) -> (Vec<keycomp_describe::Descriptor>, &[f32]) {
        let d = self.hypothesis(h);
        (
            d.components.iter().map(|c| c.descriptor).collect(),
            &d.layout,
        )
    }

    /// Its parts' areas as `keycomp_retrieval::ShapeView::areas` wants them (the same
    /// quantity `keycomp_retrieval::record_areas` gives for an indexed shape): area fractions
    /// when scale-free, times the surface area in file units; empty when `params` has the area
    /// check off.
    pub fn areas(&self, params: &keycomp_retrieval::MatchParams) -> Vec<f32> {
        self.areas_of(0, params)
    }

    /// [`Analysed::areas`] under scale hypothesis `h`.
    pub fn areas_of(&self, h: usize, params: &keycomp_retrieval::MatchParams) -> Vec<f32> {
        if params.area_tolerance <= 1.0 {
            return Vec::new();
        }
        let unit = match self.units {
            keycomp_describe::Units::ScaleFree => 1.0,
            keycomp_describe::Units::File { .. } => self.detection_of(h).area,
        };
        self.hypothesis(h)
            .components
            .iter()
            .map(|c| (c.area * unit) as f32)
            .collect()
    }

    /// Its parts' centre positions as `keycomp_retrieval::ShapeView::centres` wants them;
    /// empty when `params` has the pose check and verification off.
    pub fn centres(&self, params: &keycomp_retrieval::MatchParams) -> Vec<[f32; 3]> {
        self.centres_of(0, params)
    }

    /// [`Analysed::centres`] under scale hypothesis `h`.
    pub fn centres_of(&self, h: usize, params: &keycomp_retrieval::MatchParams) -> Vec<[f32; 3]> {
        if params.pose_weight <= 0.0 && params.verify_weight <= 0.0 {
            return Vec::new();
        }
        self.hypothesis(h)
            .components
            .iter()
            .map(|c| c.position)
            .collect()
    }

    /// Its surface as a mesh in its file's coordinates, for a pose's refinement: the mesh as
    /// read, or, for points, its analysed (canonical) surface.
    pub fn surface_mesh(&self) -> &Mesh {
        match &self.input {
            Geometry::Mesh(m) if m.num_faces() > 0 => m,
            _ => &self.mesh,
        }
    }

    /// The frame factor of its description under scale hypothesis `h`
    /// ([`crate::transform::frame_factor`]): its parts' positions and sample are its analysed
    /// mesh's coordinates times this.
    pub fn frame_factor(&self, h: usize) -> f64 {
        crate::transform::frame_factor(
            self.units,
            keycomp_mesh::geometry::total_area(self.mesh_of(h)),
        )
    }

    /// Its view under scale hypothesis `h` with its parts' centres and its surface sample,
    /// whatever the matching parameters ask for (for an alignment).
    pub fn full_view_of(&self, h: usize) -> (Vec<keycomp_describe::Descriptor>, Vec<[f32; 3]>) {
        let d = self.hypothesis(h);
        (
            d.components.iter().map(|c| c.descriptor).collect(),
            d.components.iter().map(|c| c.position).collect(),
        )
    }

    /// Where this shape, as the query under scale hypothesis `h`, sits on `target` (of frame
    /// factor `target_frame`): the alignment of the match `m` when its verification found one,
    /// else one found now by verification's search (`keycomp_retrieval::align_views`), then
    /// the other distinct poses verification passed on (`keycomp_retrieval::ShapeMatch::alternatives`,
    /// for [`crate::transform::Transform::refined_best`]); empty when no alignment is found.
    pub fn transforms_onto(
        &self,
        h: usize,
        m: &keycomp_retrieval::ShapeMatch,
        target: keycomp_retrieval::ShapeView,
        target_frame: f64,
        params: &keycomp_retrieval::MatchParams,
    ) -> Vec<crate::transform::Transform> {
        let (alignments, fitness) = match (&m.alignment, m.verified) {
            (Some(a), Some(f)) => {
                let mut all = vec![*a];
                all.extend(m.alternatives.iter().copied());
                (all, f)
            }
            _ => {
                let (descriptors, centres) = self.full_view_of(h);
                let query = keycomp_retrieval::ShapeView {
                    descriptors: &descriptors,
                    layout: &self.hypothesis(h).layout,
                    areas: &[],
                    centres: &centres,
                    sample: &self.hypothesis(h).sample,
                };
                match keycomp_retrieval::align_views(query, target, &self.match_params(params)) {
                    Some(found) => found,
                    None => return Vec::new(),
                }
            }
        };
        alignments
            .iter()
            .filter_map(|a| {
                crate::transform::Transform::from_alignment(
                    a,
                    self.frame_factor(h),
                    target_frame,
                    fitness,
                )
            })
            .collect()
    }

    /// Vertices on the mesh's boundary: 0 for a closed surface (see
    /// `keycomp_retrieval::verify_weight_for`).
    pub fn boundary_vertices(&self) -> usize {
        self.description.boundary_vertices
    }

    /// Whether it was described in file units (`keycomp_describe::Units::File`).
    pub fn file_units(&self) -> bool {
        matches!(self.units, keycomp_describe::Units::File { .. })
    }

    /// Verification's weight with this shape as the query: `weight` when given, else by its
    /// boundary, unit mode and surface (`keycomp_retrieval::verify_weight_for`).
    pub fn verify_weight(&self, weight: Option<f64>) -> f64 {
        keycomp_retrieval::verify_weight_for(
            self.boundary_vertices(),
            self.file_units() || self.canonical,
            weight,
        )
    }

    /// Its surface sample as `keycomp_retrieval::ShapeView::sample` wants it; empty when
    /// `params` has verification off.
    pub fn sample(&self, params: &keycomp_retrieval::MatchParams) -> &[[f32; 3]] {
        self.sample_of(0, params)
    }

    /// [`Analysed::sample`] under scale hypothesis `h`.
    pub fn sample_of(&self, h: usize, params: &keycomp_retrieval::MatchParams) -> &[[f32; 3]] {
        if params.verify_weight <= 0.0 {
            return &[];
        }
        &self.hypothesis(h).sample
    }

    /// The matching parameters for shapes described like this one: `base` with
    /// `file_units` set from [`Analysed::units`] and verification's search from its surface
    /// (`keycomp_retrieval::verify_search_for`).
    pub fn match_params(
        &self,
        base: &keycomp_retrieval::MatchParams,
    ) -> keycomp_retrieval::MatchParams {
        keycomp_retrieval::MatchParams {
            file_units: self.file_units(),
            verify_search: keycomp_retrieval::verify_search_for(self.canonical),
            ..*base
        }
    }

    /// Part-to-part matching of this shape (as the query) against `other` (Kuhn–Munkres on
    /// descriptor distances, then the layout and area checks; `keycomp_retrieval::match_shapes`),
    /// under each of its scale hypotheses: the best match, and the hypothesis that gave it
    /// (the first on ties).
    pub fn match_with(
        &self,
        other: &Analysed,
        params: &keycomp_retrieval::MatchParams,
    ) -> (keycomp_retrieval::ShapeMatch, usize) {
        let mut best = (self.match_hypothesis(0, other, params), 0);
        for h in 1..self.hypothesis_count() {
            let m = self.match_hypothesis(h, other, params);
            if m.score > best.0.score {
                best = (m, h);
            }
        }
        best
    }

    fn match_hypothesis(
        &self,
        h: usize,
        other: &Analysed,
        params: &keycomp_retrieval::MatchParams,
    ) -> keycomp_retrieval::ShapeMatch {
        let params = self.match_params(params);
        let (da, la) = self.view_of(h);
        let (db, lb) = other.view();
        let (aa, ab) = (self.areas_of(h, &params), other.areas(&params));
        let (ca, cb) = (self.centres_of(h, &params), other.centres(&params));
        keycomp_retrieval::match_shapes(
            keycomp_retrieval::ShapeView {
                descriptors: &da,
                layout: la,
                areas: &aa,
                centres: &ca,
                sample: self.sample_of(h, &params),
            },
            keycomp_retrieval::ShapeView {
                descriptors: &db,
                layout: lb,
                areas: &ab,
                centres: &cb,
                sample: other.sample(&params),
            },
            &params,
        )
    }

    /// The index record of this analysis, for a shape known by `path` (its identity in the
    /// index is the path's canonical form) whose file has content hash `hash`.
    pub fn record(&self, path: &Path, hash: ContentHash) -> ShapeRecord<DIM> {
        self.record_of(0, path, hash)
    }

    /// [`Analysed::record`] of each scale hypothesis, in their order.
    pub fn records(&self, path: &Path, hash: ContentHash) -> Vec<ShapeRecord<DIM>> {
        (0..self.hypothesis_count())
            .map(|h| self.record_of(h, path, hash))
            .collect()
    }

    fn record_of(&self, h: usize, path: &Path, hash: ContentHash) -> ShapeRecord<DIM> {
        let d = self.hypothesis(h);
        ShapeRecord {
            path: path.to_path_buf(),
            canonical_path: canonical_path(path),
            content_hash: hash,
            vertex_count: self.mesh_of(h).num_vertices() as u32,
            face_count: self.mesh_of(h).num_faces() as u32,
            surface_area: self.detection_of(h).area,
            components: d
                .components
                .iter()
                .map(|c| ComponentRecord {
                    descriptor: c.descriptor,
                    centre_vertex: c.center,
                    area_fraction: c.area as f32,
                    keypoint_count: c.keypoints as u32,
                    centre: Some(c.position),
                })
                .collect(),
            layout: d.layout.clone(),
            sample: d.sample.clone(),
            boundary_vertices: u32::try_from(self.boundary_vertices()).unwrap_or(u32::MAX),
        }
    }
}

/// The profile under which a query is analysed for the index at `dir`, whose recorded profile
/// is `recorded` (empty for an index written by an older keycomp) and which holds `shapes`
/// shapes: always the index's description parameters (its length unit included), and its
/// detection parameters unless the query asks for others (`mine`, from the query's options;
/// `mine_is_default` when no option was given). Another descriptor version, other detection
/// parameters asked for explicitly, or an index with shapes but no readable profile is an
/// [`Error::Incomparable`] saying what to do: their descriptors would not be comparable.
pub fn query_profile(
    dir: &Path,
    recorded: &str,
    shapes: usize,
    mine: &Profile,
    mine_is_default: bool,
) -> Result<Profile, Error> {
    let rebuild =
        "rebuild it (delete the directory and `keycomp index add` again) or use another --index";
    if recorded.is_empty() {
        if shapes == 0 {
            return Ok(mine.clone());
        }
        return Err(Error::Incomparable(format!(
            "index {} has no profile (written by an older keycomp): its descriptors may not be comparable with this keycomp's; {rebuild}",
            dir.display()
        )));
    }
    let theirs: Profile = serde_json::from_str(recorded).map_err(|_| {
        Error::Incomparable(format!(
            "index {}: unreadable profile {recorded:?}; {rebuild}",
            dir.display()
        ))
    })?;
    if theirs.descriptor_version != mine.descriptor_version {
        return Err(Error::Incomparable(format!(
            "index {} holds descriptors of version {} ({:?}), this keycomp makes version {} ({:?}); {rebuild}",
            dir.display(),
            theirs.descriptor_version,
            theirs.describe,
            mine.descriptor_version,
            mine.describe
        )));
    }
    // the surface, and with it whether Harris skips fits at a border, is the index's
    let mut asked = mine.detect.clone();
    asked.harris.skip_boundary = theirs.detect.harris.skip_boundary;
    if theirs.detect == asked || mine_is_default {
        return Ok(theirs);
    }
    Err(Error::Incomparable(format!(
        "index {} was built with other detection parameters than the query's options give: index {}, query {}; drop the options to use the index's",
        dir.display(),
        serde_json::to_string(&theirs.detect)?,
        serde_json::to_string(&mine.detect)?
    )))
}

/// The files named, and the supported mesh files (by extension) below the folders named, each
/// folder's sorted by path so the order is reproducible. A named file is kept whatever its
/// extension (reading it then says what is wrong); a path that does not exist is an error,
/// before anything else is done.
pub fn mesh_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut stack = vec![p.clone()];
            while let Some(d) = stack.pop() {
                let mut entries: Vec<PathBuf> = std::fs::read_dir(&d)
                    .map_err(|e| Error::Path {
                        path: d.clone(),
                        reason: format!("cannot read the folder: {e}"),
                    })?
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .collect();
                entries.sort();
                for e in entries.into_iter().rev() {
                    if e.is_dir() {
                        stack.push(e);
                    } else if Format::from_path(&e).is_ok() {
                        out.push(e);
                    }
                }
            }
        } else if p.exists() {
            out.push(p.clone());
        } else {
            return Err(Error::Path {
                path: p.clone(),
                reason: "no such file or folder".into(),
            });
        }
    }
    Ok(out)
}

/// Records of `files`, in parallel, one per file: `None` for a file whose content hash equals
/// `known(its canonical path)` (an index already holding it: each file is hashed once, and a
/// known one is skipped before any other work), else the record or why it could not be made.
/// Calls `done` after each file (for progress).
pub fn records_of_new(
    files: &[PathBuf],
    profile: &Profile,
    known: impl Fn(&Path) -> Option<ContentHash>,
    done: impl Fn() + Sync,
) -> Vec<Option<Result<Recorded, Error>>> {
    let known: Vec<Option<ContentHash>> = files.iter().map(|p| known(&canonical_path(p))).collect();
    files
        .par_iter()
        .zip(known)
        .map(|(p, old)| {
            let r = match ContentHash::of_file(p) {
                Err(e) => Some(Err(e.into())),
                Ok(hash) if old == Some(hash) => None,
                Ok(hash) => Some(analyse(p, profile).map(|a| Recorded {
                    record: a.record(p, hash),
                    warnings: a.warnings,
                })),
            };
            done();
            r
        })
        .collect()
}

/// An index record and what the reader tolerated on the way ([`Analysed::warnings`]).
#[derive(Debug, Clone)]
pub struct Recorded {
    /// The record.
    pub record: ShapeRecord<DIM>,
    /// The reader's warnings (unknown header lines, dropped points, ...).
    pub warnings: Vec<String>,
}

/// Reads, detects and describes one file, whose content hash is `hash`, into an index record.
pub fn record_of(
    path: &Path,
    hash: ContentHash,
    profile: &Profile,
) -> Result<ShapeRecord<DIM>, Error> {
    Ok(analyse(path, profile)?.record(path, hash))
}

/// [`record_of`] for a mesh analysed as `role`: one record per description (a query's
/// records, one per scale hypothesis, for `keycomp_retrieval::rank_hypotheses`).
pub fn records_as(
    path: &Path,
    hash: ContentHash,
    profile: &Profile,
    role: Role,
) -> Result<Vec<ShapeRecord<DIM>>, Error> {
    Ok(analyse_as(path, profile, role)?.records(path, hash))
}

/// Detects and describes a mesh in memory into an index record under the name `path` (which
/// need not exist as a file); its content hash is that of the mesh's positions and faces.
pub fn record_of_mesh(
    mesh: Mesh,
    path: &Path,
    profile: &Profile,
) -> Result<ShapeRecord<DIM>, Error> {
    let mut bytes = Vec::with_capacity(24 * mesh.positions.len() + 12 * mesh.faces.len());
    for p in &mesh.positions {
        for c in [p.x, p.y, p.z] {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in &mesh.faces {
        for v in f {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let hash = ContentHash::of_bytes(&bytes);
    Ok(analyse_mesh(mesh, profile)?.record(path, hash))
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_describe::describe_with;
    use keycomp_mesh::{synth, write_off};

    /// A mesh analysed in memory gives the parts of the same mesh read from a file, and its
    /// record names the given path with a hash of the geometry.
    #[test]
    fn in_memory_equals_from_file() {
        let mesh = synth::textured_protrusion_sphere(4);
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("shape.off");
        write_off(&mesh, &path).expect("write");
        let profile = Profile::current(&DetectParams::default());
        let from_file = analyse(&path, &profile).expect("analyse");
        let in_memory = analyse_mesh(mesh.clone(), &profile).expect("analyse_mesh");
        assert_eq!(from_file.view().0, in_memory.view().0);
        assert_eq!(from_file.view().1, in_memory.view().1);
        let a = record_of_mesh(mesh.clone(), Path::new("named.off"), &profile).expect("record");
        let b = record_of_mesh(mesh, Path::new("named.off"), &profile).expect("record");
        assert_eq!(a, b);
        assert_eq!(a.path, Path::new("named.off"));
        assert_eq!(a.components.len(), from_file.description.components.len());
        let e = analyse(&dir.path().join("missing.off"), &profile)
            .map(|_| ())
            .unwrap_err();
        assert!(e.to_string().contains("missing.off"), "{e}");
    }

    /// Under a version 1 profile, a scale-free query with a boundary is described under each
    /// scale hypothesis with the patch radii of `DescribeParams::for_query_with_boundary`, on
    /// one detection; a closed query, an indexed shape and a file-unit query have one
    /// description. A match keeps the best hypothesis's score, and `select` makes it the
    /// description.
    #[test]
    fn first_version_fragment_queries_get_one_description_per_scale_hypothesis() {
        let whole = synth::textured_protrusion_sphere(5);
        let (half, _) = keycomp_mesh::cut::cut_by_plane(
            &whole,
            keycomp_mesh::Point3::origin(),
            keycomp_mesh::Vector3::z(),
        );
        let old = |params: &DetectParams, describe: DescribeParams| Profile {
            version: 1,
            ..Profile::with(params, describe).with_surface(None)
        };
        let profile = old(&DetectParams::default(), DescribeParams::default());
        let q = analyse_mesh_as(half.clone(), &profile, Role::Query).expect("analyse");
        let hypotheses = profile.describe.for_query_with_boundary(true);
        assert_eq!(q.hypothesis_count(), hypotheses.len());
        assert!(q.hypothesis_count() > 1);
        for (h, params) in hypotheses.iter().enumerate() {
            let det = detect(&half, &profile.detect).expect("detect");
            let d = describe_with(&half, &det, params).expect("describe");
            assert_eq!(q.hypothesis(h), &d, "hypothesis {h}");
        }
        let indexed = analyse_mesh(half.clone(), &profile).expect("analyse");
        assert_eq!(indexed.hypothesis_count(), 1);
        let det = detect(&half, &profile.detect).expect("detect");
        let as_indexed = describe_with(&half, &det, &profile.describe).expect("describe");
        assert_eq!(indexed.description, as_indexed);
        let closed = analyse_mesh_as(whole.clone(), &profile, Role::Query).expect("analyse");
        assert_eq!(closed.hypothesis_count(), 1);
        let file = old(
            &DetectParams::default(),
            DescribeParams {
                units: keycomp_describe::Units::File { length: 1.0 },
                ..DescribeParams::default()
            },
        );
        let in_file = analyse_mesh_as(half.clone(), &file, Role::Query).expect("analyse");
        assert_eq!(in_file.hypothesis_count(), 1);
        // the match is the best hypothesis's
        let target = analyse_mesh(whole, &profile).expect("analyse");
        let params = keycomp_retrieval::MatchParams::default();
        let (m, h) = q.match_with(&target, &params);
        for other in 0..q.hypothesis_count() {
            assert!(q.match_hypothesis(other, &target, &params).score <= m.score);
        }
        let mut chosen = analyse_mesh_as(half, &profile, Role::Query).expect("analyse");
        chosen.select(h);
        assert_eq!(&chosen.description, q.hypothesis(h));
        assert_eq!(chosen.hypothesis_count(), q.hypothesis_count());
        let (again, h0) = chosen.match_with(&target, &params);
        assert_eq!((again.score, h0), (m.score, 0));
    }

    /// Under the current profile a scale-free query with a boundary is analysed once per
    /// share of [`FRAGMENT_SHARES`]: its canonical surface sampled at the density of the
    /// source that share implies (about share × the budget's vertices), detected and described
    /// in that source's unit, its positions and sample in its own unit-area frame. An indexed
    /// shape, a closed query and a query in file units are analysed once. `select` swaps a
    /// hypothesis's mesh, detection and description in together.
    #[test]
    fn fragment_queries_get_one_analysis_per_share_of_their_source() {
        let whole = synth::textured_protrusion_sphere(5);
        let (half, _) = keycomp_mesh::cut::cut_by_plane(
            &whole,
            keycomp_mesh::Point3::origin(),
            keycomp_mesh::Vector3::z(),
        );
        let profile =
            Profile::current(&crate::options::DetectOptions::default().retrieval_params());
        assert_eq!(profile.version, Profile::VERSION);
        assert!(profile.surface.is_some());
        let budget = profile.surface.unwrap_or_default().vertices as f64;
        let q = analyse_mesh_as(half.clone(), &profile, Role::Query).expect("analyse");
        assert_eq!(q.hypothesis_count(), FRAGMENT_SHARES.len());
        let extent = |sample: &[[f32; 3]]| {
            sample
                .iter()
                .map(|p| (p[0] as f64).hypot(p[1] as f64))
                .fold(0.0, f64::max)
        };
        let own = extent(
            &analyse_mesh(half.clone(), &profile)
                .expect("analyse")
                .description
                .sample,
        );
        for (h, &share) in FRAGMENT_SHARES.iter().enumerate() {
            assert_eq!(q.share_of(h), share);
            let n = q.mesh_of(h).num_vertices() as f64;
            assert!(
                (n / (share * budget) - 1.0).abs() < 0.35,
                "hypothesis {h}: {n} vertices"
            );
            // the description's ids are its own mesh's
            let d = q.hypothesis(h);
            assert!(d.boundary_vertices > 0);
            assert!(d.components.iter().all(|c| {
                c.vertices
                    .iter()
                    .all(|&v| (v as usize) < q.mesh_of(h).num_vertices())
            }));
            // measured in the source's unit, the half of a sphere taken for a share f of a
            // source keeps about f of it in keypoints per unit area
            let det = q.detection_of(h);
            assert!((det.scale - (share / det.area).sqrt()).abs() < 1e-9 * det.scale);
            // positions and samples in the half's own unit-area frame, as an indexed half's
            let r = extent(&d.sample);
            assert!(
                (r / own - 1.0).abs() < 0.05,
                "sample extent {r}, the half's own {own}"
            );
        }
        for (mesh, role) in [(whole.clone(), Role::Query), (half.clone(), Role::Indexed)] {
            let one = analyse_mesh_as(mesh, &profile, role).expect("analyse");
            assert_eq!(one.hypothesis_count(), 1);
            assert_eq!(one.share, 1.0);
        }
        let file = Profile::with(
            &profile.detect,
            DescribeParams {
                units: keycomp_describe::Units::File { length: 1.0 },
                ..DescribeParams::default()
            },
        );
        let in_file = analyse_mesh_as(half.clone(), &file, Role::Query).expect("analyse");
        assert_eq!(in_file.hypothesis_count(), 1);
        // select brings a hypothesis's mesh, detection and description in together
        let mut chosen = analyse_mesh_as(half, &profile, Role::Query).expect("analyse");
        chosen.select(1);
        assert_eq!(chosen.mesh, *q.mesh_of(1));
        assert_eq!(&chosen.description, q.hypothesis(1));
        assert_eq!(chosen.share, FRAGMENT_SHARES[1]);
        assert_eq!(chosen.mesh_of(1), &q.mesh);
        let target = analyse_mesh(whole, &profile).expect("analyse");
        let params = keycomp_retrieval::MatchParams::default();
        let (m, _) = q.match_with(&target, &params);
        assert!(m.score > 0.0);
    }
}
