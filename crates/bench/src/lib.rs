//! SHREC'10-style robustness benchmark for keycomp: mesh transformations with a ground-truth
//! vertex correspondence ([`transform`](mod@transform)), and the overlap / repeatability measures of Sipiran &
//! Bustos (2013), Section 4.2 ([`evaluate`]).
//!
//! A benchmark run takes a null shape X, produces transformed shapes Y = T(X) of eight kinds at
//! five strengths each (the SHREC'10 feature detection benchmark, Bronstein et al., 3DOR 2010;
//! isometry comes from real pose data instead), detects components on X and on every Y, carries
//! the components of Y back to X through the correspondence ([`evaluate::Pullback`]) and scores
//! each one by its best area overlap with a component of X ([`evaluate::best_overlaps`]).
//!
//! [`experiment`] runs the whole protocol of the paper's Section 4 on a data folder and builds
//! its Tables 1–3 and Figs. 7–9 ([`svg`]) next to the published numbers ([`paper`]); detection
//! is split in a clustering-independent stage and a per-preset stage ([`staged`]) whose first
//! half is cached on disk by content ([`cache`]).
//!
//! [`retrieval`] measures retrieval quality (Princeton Shape Benchmark measures, the D2 and
//! FPFH baselines) for `keycomp bench retrieval`. The bench is a client of the product crates:
//! it uses none of its code in the `keycomp` library or command line.

pub mod cache;
mod error;
pub mod evaluate;
pub mod experiment;
mod graph;
pub mod paper;
pub mod retrieval;
pub mod staged;
pub mod svg;
pub mod transform;

pub use error::BenchError;
pub use evaluate::{
    CumulativeTable, Pullback, Record, TableRow, best_overlaps, cumulative_table,
    mean_overlap_table, overlap, repeatability, repeatability_curve, repeatability_table,
};
pub use transform::{
    Kind, MapFile, Transformed, format_map, parse_map, read_map, transform, write_map,
};
