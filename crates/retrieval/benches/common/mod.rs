#![allow(dead_code)] // each bench uses a part of this module
//! What this crate's scale benches (`query_scale`, `ann_compare`, `search_effort`) share: the
//! grown copies of real records, the queries made of indexed records, resident memory. Their
//! command line under `cargo bench`, paths from the workspace root and medians come from
//! `keycomp_test_support`.

use std::path::PathBuf;

use keycomp_describe::DIM;
use keycomp_index::{IndexReader, ShapeId, ShapeRecord};
use keycomp_retrieval::ShapeView;
use keycomp_test_support::workspace_path;
use rand::Rng;

/// The path in the environment variable `var`, a relative one taken from the workspace root
/// (`cargo bench` runs a bench in its crate's folder).
pub fn env_path(var: &str) -> Option<PathBuf> {
    std::env::var_os(var).map(workspace_path)
}

/// Copy `i` of the records `src` (record `i mod len`), with its own path and content hash and
/// every descriptor value moved by up to ±0.01 (draws from `jitter`, part after part).
/// `src` must not be empty.
pub fn grown_copy(src: &[ShapeRecord<DIM>], i: u64, jitter: &mut impl Rng) -> ShapeRecord<DIM> {
    let mut r = src[i as usize % src.len()].clone();
    let name = format!("copy-{i:07}.off");
    r.path = std::path::PathBuf::from("copies").join(&name);
    r.canonical_path = std::path::PathBuf::from("/copies").join(&name);
    r.content_hash = keycomp_index::ContentHash::of_bytes(&i.to_le_bytes());
    for c in &mut r.components {
        for x in &mut c.descriptor {
            *x += jitter.random_range(-0.01..0.01);
        }
    }
    r
}

/// The first number after `key` in the Linux process file `/proc/self/FILE` (`None`
/// elsewhere).
fn proc_number(file: &str, key: &str) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/self/{file}")).ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// The process's resident memory in MB (Linux; `None` elsewhere).
pub fn resident_mb() -> Option<f64> {
    Some(proc_number("status", "VmRSS:")? as f64 / 1e3)
}

/// Bytes this process has had read from the storage device so far (Linux, from
/// `/proc/self/io`: reads served by the page cache are not counted).
pub fn disk_read_bytes() -> Option<u64> {
    proc_number("io", "read_bytes:")
}

/// A query: its part descriptors and its layout.
pub type Query = (Vec<[f32; DIM]>, Vec<f32>);

/// A query made of the indexed shape `id`'s record: its descriptors with every value moved by
/// up to ±0.01 (draws from `rng`, part after part), and its layout. `None` if `id` has no
/// record.
pub fn perturbed_query(
    reader: &IndexReader<DIM>,
    id: ShapeId,
    rng: &mut impl Rng,
) -> Result<Option<Query>, keycomp_index::IndexError> {
    let Some(rec) = reader.get(id)? else {
        return Ok(None);
    };
    let descs = rec
        .components
        .iter()
        .map(|c| {
            let mut d = c.descriptor;
            for x in &mut d {
                *x += rng.random_range(-0.01..0.01);
            }
            d
        })
        .collect();
    Ok(Some((descs, rec.layout.clone())))
}

/// A query's matching view (no area check: the copies' areas are not perturbed).
pub fn view<'a>(descriptors: &'a [[f32; DIM]], layout: &'a [f32]) -> ShapeView<'a> {
    ShapeView {
        descriptors,
        layout,
        areas: &[],
        centres: &[],
        sample: &[],
    }
}
