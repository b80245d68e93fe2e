//! A collection's index as the product uses it: add mesh files or meshes in memory (each
//! analysed under the index's [`Profile`]), remove shapes or whole folders, merge indexes
//! built apart. `keycomp index add|remove|merge` and the Python package are built on these;
//! the on-disk format itself is `keycomp_index`'s.

use std::path::{Path, PathBuf};

use keycomp_components::DetectParams;
use keycomp_describe::{DIM, DescribeParams};
use keycomp_index::{IndexReader, IndexWriter, MANIFEST_NAME, ShapeRecord, canonical_path};
use keycomp_mesh::{Mesh, read_mesh};
use keycomp_surface::SurfaceParams;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::folders::check_output_folder;
use crate::{Error, Profile, mesh_files, record_of_mesh, records_of_new};

/// An index writer with the description's descriptor length.
pub type Writer = IndexWriter<DIM>;
/// An index reader with the description's descriptor length.
pub type Reader = IndexReader<DIM>;

/// Shapes analysed before each commit to disk when failures do not stop an add.
const BATCH: usize = 32;

/// The length unit of a description.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Units {
    /// Every mesh scaled to unit area on its own (the default).
    #[default]
    ScaleFree,
    /// The files' own units (a collection and its queries in the same real units: CAD in mm,
    /// calibrated scans), so that a fragment keeps its source's scale.
    File {
        /// The length unit in file units; `None`: the square root of the median surface area
        /// of the shapes described first ([`unit_from_areas`]).
        length: Option<f64>,
    },
}

impl Units {
    /// Whether these are file units.
    pub fn is_file(self) -> bool {
        matches!(self, Units::File { .. })
    }

    /// The description parameters of these units; `areas` gives the surface areas whose median
    /// sets a file unit not given (called only then).
    pub fn describe_params(
        self,
        areas: impl FnOnce() -> Vec<f64>,
    ) -> Result<DescribeParams, Error> {
        let length = match self {
            Units::ScaleFree => return Ok(DescribeParams::default()),
            Units::File { length: Some(l) } if l.is_finite() && l > 0.0 => l,
            Units::File { length: Some(l) } => {
                return Err(Error::Invalid(format!(
                    "the unit length must be a positive number of file units, got {l}"
                )));
            }
            Units::File { length: None } => unit_from_areas(areas())?,
        };
        Ok(DescribeParams {
            units: keycomp_describe::Units::File { length },
            ..DescribeParams::default()
        })
    }
}

/// The length unit of a collection in file units: the square root of its median surface area
/// (areas that are not positive numbers left out).
pub fn unit_from_areas(mut areas: Vec<f64>) -> Result<f64, Error> {
    areas.retain(|a| a.is_finite() && *a > 0.0);
    if areas.is_empty() {
        return Err(Error::Invalid(
            "file units: no shape with a positive surface area to choose the length unit from"
                .into(),
        ));
    }
    areas.sort_by(f64::total_cmp);
    Ok(areas[areas.len() / 2].sqrt())
}

/// Surface areas of the readable meshes among `files` (unreadable ones are left out: they fail
/// with a clear message when analysed).
pub fn areas_of(files: &[PathBuf]) -> Vec<f64> {
    files
        .par_iter()
        .filter_map(|p| read_mesh(p).ok())
        .map(|m| keycomp_mesh::geometry::total_area(&m.mesh))
        .collect()
}

/// How [`add`] analyses and stores shapes.
#[derive(Debug, Clone, Default)]
pub struct AddOptions {
    /// Detection parameters; `None`: the index's (the retrieval default for a new index).
    /// Parameters other than an index's are refused: its descriptors would not be comparable.
    pub detect: Option<DetectParams>,
    /// Length unit; `None`: the index's (scale-free for a new index). Other units than an
    /// index's are refused.
    pub units: Option<Units>,
    /// Canonical surface (`true`) or meshes as read (`false`); `None`: the index's (the
    /// canonical surface for a new index). Another choice than an index's is refused.
    pub canonical: Option<bool>,
    /// `true`: a file that cannot be analysed is listed in [`AddSummary::failed`] and the others
    /// are stored, in commits of 32 shapes (the command line). `false`: the first failure is
    /// returned as the error and nothing of the call is stored (one commit).
    pub keep_going: bool,
}

/// A file that could not be added, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// The file.
    pub path: PathBuf,
    /// The error, naming the file.
    pub message: String,
}

/// What [`add`] did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AddSummary {
    /// Shapes new to the index.
    pub added: usize,
    /// Shapes stored again because their file changed.
    pub replaced: usize,
    /// Shapes already indexed with the same content (not analysed again).
    pub unchanged: usize,
    /// Files that could not be analysed (only with [`AddOptions::keep_going`]).
    pub failed: Vec<Failure>,
    /// Shapes in the index afterwards.
    pub shapes: usize,
}

/// Progress of [`add`]: called from the analysing threads.
pub trait Progress: Sync {
    /// The files to analyse are listed: `count` of them.
    fn files(&self, _count: usize) {}
    /// One file is done (analysed, skipped as unchanged, or failed).
    fn file_done(&self) {}
    /// A file failed (with [`AddOptions::keep_going`]).
    fn failed(&self, _failure: &Failure) {}
    /// A file was read with a warning (an unknown header line, dropped points, ...): `message`
    /// names the file.
    fn warned(&self, _message: &str) {}
}

impl Progress for () {}

/// Opens (creating it if needed, under an existing parent folder) the index at `dir` and
/// settles the profile of an add: the index's, where options do not ask for another;
/// `areas` gives the surface areas that set a file unit not given, for a new index.
fn open_for_add(
    dir: &Path,
    options: &AddOptions,
    areas: impl FnOnce() -> Vec<f64>,
) -> Result<(Writer, Profile), Error> {
    check_output_folder(dir)?;
    let mut writer = Writer::create_or_open(dir)?;
    let recorded = writer.profile().to_string();
    let existing: Option<Profile> = match serde_json::from_str::<Profile>(&recorded) {
        Ok(p) => Some(p),
        Err(_) if recorded.is_empty() && writer.is_empty() => None,
        Err(_) => {
            return Err(Error::Incomparable(format!(
                "index {} has no readable profile (written by an older keycomp?); rebuild it \
                 (delete the folder and add the shapes again) or use another index",
                dir.display()
            )));
        }
    };
    let profile = match existing.clone() {
        Some(p) => {
            let file = matches!(p.describe.units, keycomp_describe::Units::File { .. });
            if let Some(u) = options.units
                && u.is_file() != file
            {
                return Err(Error::Incomparable(format!(
                    "index {} describes shapes in {} units; drop the units option or use \
                     another index",
                    dir.display(),
                    if file { "file" } else { "scale-free" }
                )));
            }
            if let Some(c) = options.canonical
                && c != p.surface.is_some()
            {
                return Err(Error::Incomparable(format!(
                    "index {} analyses {}; drop the surface option or use another index",
                    dir.display(),
                    if p.surface.is_some() {
                        "canonical surfaces"
                    } else {
                        "meshes as read"
                    }
                )));
            }
            // the recorded detection parameters already carry the surface's Harris setting
            let detect = options.detect.clone().unwrap_or_else(|| p.detect.clone());
            Profile {
                version: p.version,
                ..Profile::with(&detect, p.describe).with_surface(p.surface)
            }
        }
        None => {
            let detect = options
                .detect
                .clone()
                .unwrap_or_else(|| crate::options::DetectOptions::default().retrieval_params());
            let describe = options.units.unwrap_or_default().describe_params(areas)?;
            Profile::with(&detect, describe).with_surface(
                options
                    .canonical
                    .unwrap_or(true)
                    .then(SurfaceParams::default),
            )
        }
    };
    // the recorded text where nothing changed: a profile written before a parameter existed
    // reads with that parameter's old behaviour but would not print as it is recorded
    let text = if existing.as_ref() == Some(&profile) {
        recorded
    } else {
        profile.to_text()?
    };
    writer.ensure_profile(&text)?;
    Ok((writer, profile))
}

/// Adds the mesh files named and every supported mesh below the folders named ([`mesh_files`])
/// to the index at `dir`, creating it if needed: files already indexed with the same content
/// are skipped, changed ones replaced, the others analysed in parallel under the index's
/// profile. Errors: a path that does not exist, no mesh file at all, options incomparable with
/// the index's profile, index errors, and (without [`AddOptions::keep_going`]) the first file
/// that cannot be analysed.
pub fn add(
    dir: &Path,
    paths: &[PathBuf],
    options: &AddOptions,
    progress: &dyn Progress,
) -> Result<AddSummary, Error> {
    let files = mesh_files(paths)?;
    if files.is_empty() {
        return Err(Error::Invalid(
            "no mesh, scan or point-cloud files (.off, .obj, .ply, .stl, .gltf, .glb, .xyz, .pts, .pcd) found in the paths given".into(),
        ));
    }
    add_items(dir, &files, Vec::new(), options, progress)
}

/// Adds meshes in memory to the index at `dir`, each stored under its name (a path that need
/// not exist; its content hash is that of the geometry, [`record_of_mesh`]).
pub fn add_meshes(
    dir: &Path,
    meshes: Vec<(PathBuf, Mesh)>,
    options: &AddOptions,
) -> Result<AddSummary, Error> {
    add_items(dir, &[], meshes, options, &())
}

/// Adds mesh files (`files`, not searched further) and meshes in memory (`meshes`, each under
/// its name) in one call: with [`AddOptions::keep_going`] files are stored in commits of 32
/// and the meshes in one more, failures listed; without it everything is one commit, made
/// only when every shape could be analysed.
pub fn add_items(
    dir: &Path,
    files: &[PathBuf],
    meshes: Vec<(PathBuf, Mesh)>,
    options: &AddOptions,
    progress: &dyn Progress,
) -> Result<AddSummary, Error> {
    progress.files(files.len());
    let (mut writer, profile) = open_for_add(dir, options, || {
        let mut areas = areas_of(files);
        areas.extend(
            meshes
                .iter()
                .map(|(_, m)| keycomp_mesh::geometry::total_area(m)),
        );
        areas
    })?;
    if let Some(note) = profile.migration_note(dir) {
        progress.warned(&note);
    }
    let mut summary = AddSummary::default();
    let mut pending = Vec::new();
    let batch = if options.keep_going {
        BATCH
    } else {
        files.len().max(1)
    };
    let outcome = |path: &Path,
                   r: Result<ShapeRecord<DIM>, Error>,
                   pending: &mut Vec<ShapeRecord<DIM>>,
                   summary: &mut AddSummary|
     -> Result<(), Error> {
        match r {
            Ok(rec) => pending.push(rec),
            Err(e) if options.keep_going => {
                let failure = Failure {
                    path: path.to_path_buf(),
                    message: naming(path, &e),
                };
                progress.failed(&failure);
                summary.failed.push(failure);
            }
            Err(e) => return Err(e),
        }
        Ok(())
    };
    for chunk in files.chunks(batch) {
        let results = records_of_new(
            chunk,
            &profile,
            |c| writer.lookup(c).map(|(_, h)| h),
            || progress.file_done(),
        );
        for (p, r) in chunk.iter().zip(results) {
            match r {
                None => summary.unchanged += 1,
                Some(r) => {
                    let r = r.map(|r| {
                        for w in &r.warnings {
                            progress.warned(&format!("{}: {w}", p.display()));
                        }
                        r.record
                    });
                    outcome(p, r, &mut pending, &mut summary)?
                }
            }
        }
        if options.keep_going {
            store(&mut writer, std::mem::take(&mut pending), &mut summary)?;
        }
    }
    let names: Vec<PathBuf> = meshes.iter().map(|(n, _)| n.clone()).collect();
    let made: Vec<Result<ShapeRecord<DIM>, Error>> = meshes
        .into_par_iter()
        .map(|(name, mesh)| record_of_mesh(mesh, &name, &profile))
        .collect();
    for (name, r) in names.iter().zip(made) {
        outcome(name, r, &mut pending, &mut summary)?;
    }
    store(&mut writer, pending, &mut summary)?;
    summary.shapes = writer.len();
    Ok(summary)
}

fn store(
    writer: &mut Writer,
    records: Vec<ShapeRecord<DIM>>,
    summary: &mut AddSummary,
) -> Result<(), Error> {
    if records.is_empty() {
        return Ok(());
    }
    let s = writer.add_batch(records)?;
    summary.added += s.added;
    summary.replaced += s.replaced;
    summary.unchanged += s.skipped;
    Ok(())
}

/// The error `e` about `path` as one line that names the file once.
fn naming(path: &Path, e: &Error) -> String {
    let why = crate::error_line(e);
    let name = path.display().to_string();
    if why.contains(&name) {
        why
    } else {
        format!("{name}: {why}")
    }
}

/// What [`remove`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct RemoveSummary {
    /// Shapes removed.
    pub removed: usize,
    /// Shapes left in the index.
    pub shapes: usize,
}

/// Removes shapes from the index at `dir` by path; a folder stands for every indexed shape
/// under it (also those whose files are gone since). An index that does not exist is an error
/// (none is created).
pub fn remove(dir: &Path, paths: &[PathBuf]) -> Result<RemoveSummary, Error> {
    if !dir.join(MANIFEST_NAME).is_file() {
        return Err(Error::Path {
            path: dir.to_path_buf(),
            reason: "not a keycomp index (no MANIFEST); nothing to remove".into(),
        });
    }
    let mut writer = Writer::create_or_open(dir)?;
    let mut all: Vec<PathBuf> = Vec::new();
    for p in paths {
        if p.is_dir() {
            let root = canonical_path(p);
            let mut under: Vec<PathBuf> = writer
                .canonical_paths()
                .filter(|c| c.starts_with(&root))
                .map(Path::to_path_buf)
                .collect();
            under.sort();
            all.extend(under);
        } else {
            all.push(p.clone());
        }
    }
    let removed = writer.remove(&all)?;
    Ok(RemoveSummary {
        removed,
        shapes: writer.len(),
    })
}

/// What [`merge`] did.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MergeSummary {
    /// Live shapes read from the sources.
    pub read: usize,
    /// Shapes stored in the destination.
    pub added: usize,
    /// Shapes already there (same path and content), stored once.
    pub duplicates: usize,
    /// Shapes in the destination afterwards.
    pub shapes: usize,
    /// Generation of the destination's manifest afterwards.
    pub generation: u64,
}

/// Merges the indexes at `sources` (built apart with the same profile, e.g. shards) into the
/// index at `dir` (created if needed, under an existing parent folder) in one commit
/// (`keycomp_index::IndexWriter::merge`). An index cannot be merged into itself.
pub fn merge(dir: &Path, sources: &[PathBuf]) -> Result<MergeSummary, Error> {
    let mut readers = Vec::with_capacity(sources.len());
    for src in sources {
        if canonical_path(src) == canonical_path(dir) {
            return Err(Error::Path {
                path: src.clone(),
                reason: "an index cannot be merged into itself".into(),
            });
        }
        readers.push(Reader::open(src)?);
    }
    check_output_folder(dir)?;
    let mut writer = Writer::create_or_open(dir)?;
    let s = writer.merge(&readers)?;
    Ok(MergeSummary {
        read: s.read,
        added: s.added,
        duplicates: s.duplicates,
        shapes: writer.len(),
        generation: s.generation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::{synth, write_off};

    fn options() -> AddOptions {
        AddOptions {
            keep_going: true,
            ..AddOptions::default()
        }
    }

    /// Files and meshes added, a bad file listed as failed, a second add unchanged, a folder
    /// removed, and the index's units kept against a request for others.
    #[test]
    fn add_remove_and_units() {
        let dir = tempfile::tempdir().expect("tempdir");
        let shapes = dir.path().join("shapes");
        std::fs::create_dir(&shapes).expect("mkdir");
        write_off(
            &synth::protrusion_sphere(3, 0.8, 0.3),
            &shapes.join("a.off"),
        )
        .expect("write");
        write_off(&synth::icosphere(3, 1.0), &shapes.join("b.off")).expect("write");
        std::fs::write(shapes.join("bad.off"), "OFF\n3 1 0\n0 0 0\n").expect("write");
        let index = dir.path().join("index");
        let s = add(&index, std::slice::from_ref(&shapes), &options(), &()).expect("add");
        assert_eq!((s.added, s.replaced, s.unchanged, s.shapes), (2, 0, 0, 2));
        assert_eq!(s.failed.len(), 1);
        assert!(s.failed[0].message.contains("bad.off"), "{:?}", s.failed);
        // without keep_going the bad file is the error and nothing is stored
        let strict = AddOptions::default();
        let e = add(&index, &[shapes.join("bad.off")], &strict, &()).unwrap_err();
        assert!(e.to_string().contains("bad.off"), "{e}");
        let again = add(&index, &[shapes.join("a.off")], &options(), &()).expect("add");
        assert_eq!((again.added, again.unchanged, again.shapes), (0, 1, 2));
        let m = add_meshes(
            &index,
            vec![(
                PathBuf::from("memory/c.off"),
                synth::torus(1.0, 0.4, 24, 12),
            )],
            &strict,
        )
        .expect("add_meshes");
        assert_eq!((m.added, m.shapes), (1, 3));
        let file_units = AddOptions {
            units: Some(Units::File { length: None }),
            ..options()
        };
        let e = add(&index, &[shapes.join("a.off")], &file_units, &()).unwrap_err();
        assert!(e.to_string().contains("scale-free units"), "{e}");
        let r = remove(&index, std::slice::from_ref(&shapes)).expect("remove");
        assert_eq!((r.removed, r.shapes), (2, 1));
        let e = remove(&dir.path().join("nothing"), &[shapes]).unwrap_err();
        assert!(e.to_string().contains("not a keycomp index"), "{e}");
        assert!(!dir.path().join("nothing").exists());
    }

    #[test]
    fn file_units_from_the_median_area() {
        assert_eq!(
            unit_from_areas(vec![9.0, 1.0, 4.0, -1.0]).expect("unit"),
            2.0
        );
        assert!(unit_from_areas(vec![0.0, f64::NAN]).is_err());
        let p = Units::File { length: Some(2.5) }
            .describe_params(Vec::new)
            .expect("params");
        assert_eq!(p.units, keycomp_describe::Units::File { length: 2.5 });
        assert!(
            Units::File { length: Some(-1.0) }
                .describe_params(Vec::new)
                .is_err()
        );
        assert_eq!(
            Units::ScaleFree.describe_params(Vec::new).expect("params"),
            DescribeParams::default()
        );
    }
}
