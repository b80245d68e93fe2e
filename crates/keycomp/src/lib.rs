//! keycomp as a library: the product's operations for programs other than the command line
//! (the `keycomp` binary and the Python package are built on it).
//!
//! - [`options`] turns detection options (a preset, then single values) into parameters;
//! - [`analysis`] reads, detects (Sipiran & Bustos 2013) and describes a mesh under an
//!   index's [`Profile`], from a file or from vertices and faces in memory, and turns the
//!   result into an index record;
//! - [`collection`] adds files or meshes to an index, removes shapes, merges indexes;
//! - [`search`] queries an index with a mesh: ranked shapes with their part-to-part matches;
//! - [`matching`] matches two meshes part to part;
//! - [`transform`] is where a query sits on a result: the similarity transform between their
//!   files' coordinates;
//! - [`json`] is the JSON form of a detection (`keycomp detect --json`);
//! - [`folders`] is the rule every output folder follows.
//!
//! Every result a program may keep or send on (summaries, rankings, matches) is
//! serde-serialisable, in the form the command line prints with `--json`. The crates below
//! hold the methods: `keycomp_mesh` (reading, writing), `keycomp_harris`, `keycomp_geodesic`,
//! `keycomp_components` (detection), `keycomp_describe` (descriptors), `keycomp_index` (the
//! on-disk index), `keycomp_retrieval` (matching and ranking), `keycomp_fragment` (fragments
//! for partial queries), `keycomp_render` (pictures); `keycomp_bench` (the benchmarks) is a
//! client of them that this library does not use.
//!
//! The crate's `examples/` run each operation on a collection generated in code, or on your
//! files: `index_folder`, `query`, `match_meshes` and `read_scan`
//! (`cargo run --release -p keycomp --example query -- INDEX QUERY`).
//!
//! ```no_run
//! use std::path::Path;
//! use keycomp::collection::{self, AddOptions};
//! use keycomp::matching::{MatchOptions, match_files};
//! use keycomp::search::Searcher;
//!
//! let index = Path::new("my-index");
//! let added = collection::add(index, &["shapes/".into()], &AddOptions::default(), &())?;
//! println!("{} shapes indexed", added.shapes);
//! let searcher = Searcher::open(index, None)?; // the index's own parameters
//! for hit in searcher.query(Path::new("scan.ply"), 5)?.results {
//!     println!("{} {:.3}", hit.path, hit.score);
//! }
//! let (_, _, m) = match_files(Path::new("a.off"), Path::new("b.off"), &MatchOptions::default())?;
//! println!("{}", serde_json::to_string(&m)?);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod analysis;
pub mod collection;
pub mod folders;
pub mod json;
pub mod matching;
pub mod options;
pub mod search;
pub mod transform;

pub use analysis::{
    Analysed, Error, Profile, Recorded, Role, analyse, analyse_as, analyse_mesh, analyse_mesh_as,
    error_line, mesh_files, query_profile, record_of, record_of_mesh, records_as, records_of_new,
};
