//! Ranking the shapes of an index against a described query: candidate shapes from the
//! index's KD-tree over component descriptors, then [`crate::match_shapes`] per candidate.
//!
//! Cost: m KD-tree searches (m query components, [`CANDIDATES_PER_COMPONENT`] neighbours each),
//! then one O(m³) assignment per distinct candidate shape (at most m ×
//! [`CANDIDATES_PER_COMPONENT`] shapes), independent of the index size beyond the searches.

use std::collections::BTreeSet;
use std::path::PathBuf;

use keycomp_describe::{DIM, Descriptor};
use keycomp_index::{IndexError, IndexReader, ShapeId};

use crate::{MatchParams, ShapeMatch, ShapeView, match_weighted};

/// Nearest components fetched from the KD-tree per query component.
pub const CANDIDATES_PER_COMPONENT: usize = 64;

/// One ranked shape.
#[derive(Debug, Clone)]
pub struct Ranked {
    /// The shape's id in the index.
    pub id: ShapeId,
    /// The shape's path as indexed.
    pub path: PathBuf,
    /// The component matching and its score.
    pub result: ShapeMatch,
}

/// Inverse frequency of each query part in the index: `ln(1 + N / (1 + s))` with N the shapes
/// in the index and s the distinct shapes among a part's [`CANDIDATES_PER_COMPONENT`] nearest
/// index components that lie within half of [`MatchParams::max_distance`] (the "documents"
/// holding the part, as in tf-idf; Sparck Jones 1972). `neighbours[i]` are part i's
/// neighbours.
pub fn idf_weights(
    neighbours: &[Vec<keycomp_index::ComponentMatch>],
    shapes: usize,
    params: &MatchParams,
) -> Vec<f64> {
    let near = (0.5 * params.max_distance).powi(2);
    neighbours
        .iter()
        .map(|nb| {
            let holders: BTreeSet<ShapeId> = nb
                .iter()
                .filter(|c| c.distance_sq < near)
                .map(|c| c.shape)
                .collect();
            (1.0 + shapes as f64 / (1.0 + holders.len() as f64)).ln()
        })
        .collect()
}

/// The `k` best shapes of `reader` for the query (descriptors and `m × m` layout), best first;
/// ties by shape id. Candidates are the shapes owning one of the nearest index components of
/// a query part; every candidate is returned, those scoring 0 included (after the others), so
/// a shape missing from the result was not a candidate.
pub fn rank(
    reader: &IndexReader<DIM>,
    descriptors: &[Descriptor],
    layout: &[f32],
    k: usize,
    params: &MatchParams,
) -> Result<Vec<Ranked>, IndexError> {
    let mut candidates = BTreeSet::new();
    let mut neighbours = Vec::with_capacity(descriptors.len());
    for d in descriptors {
        let nb = reader.nearest_components(d, CANDIDATES_PER_COMPONENT)?;
        for c in &nb {
            candidates.insert(c.shape);
        }
        neighbours.push(nb);
    }
    let weights = if params.idf {
        idf_weights(&neighbours, reader.shapes().len(), params)
    } else {
        Vec::new()
    };
    let query = ShapeView {
        descriptors,
        layout,
    };
    let mut ranked: Vec<Ranked> = candidates
        .into_iter()
        .filter_map(|id| {
            let rec = reader.get(id)?;
            let descs: Vec<Descriptor> = rec.components.iter().map(|c| c.descriptor).collect();
            let m = match_weighted(
                query,
                ShapeView {
                    descriptors: &descs,
                    layout: &rec.layout,
                },
                params,
                &weights,
            );
            Some(Ranked {
                id,
                path: rec.path.clone(),
                result: m,
            })
        })
        .collect();
    ranked.sort_by(|a, b| {
        b.result
            .score
            .total_cmp(&a.result.score)
            .then(a.id.cmp(&b.id))
    });
    ranked.truncate(k);
    Ok(ranked)
}
