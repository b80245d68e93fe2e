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

use crate::{MatchParams, ShapeMatch, ShapeView, match_shapes};

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

/// The `k` best shapes of `reader` for the query (descriptors and `m × m` layout), best first;
/// ties by shape id. Shapes scoring 0 are left out.
pub fn rank(
    reader: &IndexReader<DIM>,
    descriptors: &[Descriptor],
    layout: &[f32],
    k: usize,
    params: &MatchParams,
) -> Result<Vec<Ranked>, IndexError> {
    let mut candidates = BTreeSet::new();
    for d in descriptors {
        for c in reader.nearest_components(d, CANDIDATES_PER_COMPONENT)? {
            candidates.insert(c.shape);
        }
    }
    let query = ShapeView {
        descriptors,
        layout,
    };
    let mut ranked: Vec<Ranked> = candidates
        .into_iter()
        .filter_map(|id| {
            let rec = reader.get(id)?;
            let descs: Vec<Descriptor> = rec.components.iter().map(|c| c.descriptor).collect();
            let m = match_shapes(
                query,
                ShapeView {
                    descriptors: &descs,
                    layout: &rec.layout,
                },
                params,
            );
            (m.score > 0.0).then(|| Ranked {
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
