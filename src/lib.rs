//! keycomp as a library: the product's operations for programs other than the command line
//! (the `keycomp` binary is built on it).
//!
//! This is the first part of the facade: [`options`] turns detection options (a preset, then
//! single values) into parameters; [`analysis`] reads, detects (Sipiran & Bustos 2013) and
//! describes a mesh under an index's [`Profile`], from a file or from vertices and faces in
//! memory, and turns the result into an index record. Indexes themselves are in
//! `keycomp_index`, matching and ranking in `keycomp_retrieval`.

pub mod analysis;
pub mod json;
pub mod options;

pub use analysis::{
    Analysed, Error, Profile, analyse, analyse_mesh, mesh_files, query_profile, record_of,
    record_of_mesh, records_of_new,
};
