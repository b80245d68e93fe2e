//! Ranking the shapes of an index against a described query, in two stages: candidate shapes from
//! the index's nearest-neighbour search over part descriptors (exact, or approximate on large
//! indexes: `keycomp_index::SearchMode`), each voted for by the query parts it has near neighbours
//! for; then [`crate::match_weighted`] (the part-to-part assignment and the layout check) for the
//! [`MATCHED_CANDIDATES`] best-voted, pruned by two bounds on their score when only the top `k` are
//! asked for (their descriptors' distances, then their assignment); with verification on
//! ([`MatchParams::verify_weight`]), the [`VERIFIED_CANDIDATES`] best of those are matched again
//! with it ([`crate::verify`]) and the ranking redone.
//!
//! Cost: m searches in parallel (m query parts, [`CANDIDATES_PER_COMPONENT`] neighbours each),
//! the votes in O(m · [`CANDIDATES_PER_COMPONENT`]), the first bounds in O(m²) per candidate
//! (from the descriptors alone), then at most [`MATCHED_CANDIDATES`] assignments of O(m³) each
//! and as many layout checks (each with its record read), in parallel, independent of the
//! index size beyond the searches.

use std::collections::{BTreeMap, BTreeSet};

use rayon::prelude::*;
use std::path::PathBuf;

use keycomp_describe::{DIM, Descriptor};
use keycomp_index::{IndexError, IndexReader, ShapeId};

use crate::assign::{ComponentMatch, distances, pair};
use crate::checks::{Assigned, check};
use crate::params::{MatchParams, unit_weight};
use crate::score::{ShapeMatch, can_verify, finish, pairs_score, score_bound};
use crate::view::ShapeView;

/// Nearest components fetched from the KD-tree per query component.
pub const CANDIDATES_PER_COMPONENT: usize = 64;

/// Candidates matched part to part, the best by vote (see [`rank`]).
pub const MATCHED_CANDIDATES: usize = 100;

/// Candidates verified geometrically when verification is on
/// ([`MatchParams::verify_weight`] above 0): the best by score without it. Verification costs
/// a few milliseconds per shape ([`crate::verify`]); it re-ranks the shortlist, as spatial
/// verification re-ranks the best candidates of an image search (J. Philbin, O. Chum,
/// M. Isard, J. Sivic, A. Zisserman, "Object retrieval with large vocabularies and fast spatial
/// matching", CVPR 2007). Shapes beyond it count as verified with fitness 0.
pub const VERIFIED_CANDIDATES: usize = 32;

/// One ranked shape.
#[derive(Debug, Clone)]
pub struct Ranked {
    /// The shape's id in the index.
    pub id: ShapeId,
    /// The shape's path as indexed.
    pub path: PathBuf,
    /// The component matching and its score.
    pub result: ShapeMatch,
    /// The query's description that gave it: 0, or with [`rank_hypotheses`] the index of the
    /// scale hypothesis (the query's parts in `result` are that description's).
    pub hypothesis: usize,
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

/// The `k` best shapes of `reader` for the query (descriptors and `m × m` layout), best first.
/// Candidates are the shapes owning one of the nearest index components of a query part; the
/// [`MATCHED_CANDIDATES`] with the most votes are matched and ranked by score (ties by shape
/// id), the other candidates follow by vote with score 0. A shape missing from the result
/// (when it is not cut by `k`) was not a candidate.
pub fn rank(
    reader: &IndexReader<DIM>,
    query: ShapeView,
    k: usize,
    params: &MatchParams,
) -> Result<Vec<Ranked>, IndexError> {
    let neighbours =
        reader.nearest_components_batch(query.descriptors, CANDIDATES_PER_COMPONENT)?;
    rank_neighbours(reader, query, &neighbours, k, params)
}

/// [`rank`] given the nearest index components of each query part (`neighbours[i]`: part i's
/// [`CANDIDATES_PER_COMPONENT`] nearest, as `IndexReader::nearest_components_batch` returns
/// them), so that the searches of many queries can be made in one batch: an exact search of a
/// large index then reads its descriptors once for all of them.
pub fn rank_neighbours(
    reader: &IndexReader<DIM>,
    query: ShapeView,
    neighbours: &[Vec<keycomp_index::ComponentMatch>],
    k: usize,
    params: &MatchParams,
) -> Result<Vec<Ranked>, IndexError> {
    let votes = votes(neighbours, params);
    let weights = if params.idf {
        idf_weights(neighbours, reader.len(), params)
    } else {
        Vec::new()
    };
    // the best-voted candidates are matched; the others follow by vote with score 0
    let mut by_vote: Vec<(ShapeId, f64)> = votes.into_iter().collect();
    by_vote.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let rest = by_vote.split_off(by_vote.len().min(MATCHED_CANDIDATES));
    let mut ranked = match_candidates(reader, query, &by_vote, k, params, &weights)?;
    // the others' records are read for their paths only: asked of the disk at once, read in
    // parallel
    let others: Vec<ShapeId> = rest
        .into_iter()
        .take(k.saturating_sub(ranked.len()))
        .map(|(id, _)| id)
        .collect();
    reader.prefetch(&others);
    let paths: Vec<Option<PathBuf>> = others
        .par_iter()
        .map(|&id| Ok(reader.get(id)?.map(|rec| rec.path.clone())))
        .collect::<Result<_, IndexError>>()?;
    for (id, path) in others.into_iter().zip(paths) {
        if let Some(path) = path {
            ranked.push(Ranked {
                id,
                path,
                result: ShapeMatch::none(),
                hypothesis: 0,
            });
        }
    }
    ranked.truncate(k);
    Ok(ranked)
}

/// [`rank`] for a query described under several scale hypotheses (`views`, preferred first:
/// a fragment whose kept share of its source is unknown, described at several sizes): each
/// shape scores its best over the hypotheses ([`Ranked::hypothesis`] says which; the first on
/// ties), best first; shapes of equal score in the order of their best place in a
/// hypothesis's ranking (so that one hypothesis gives exactly [`rank`]'s order), then by id;
/// the `k` best. Costs one [`rank`] per hypothesis; one hypothesis is [`rank`] itself.
pub fn rank_hypotheses(
    reader: &IndexReader<DIM>,
    views: &[ShapeView],
    k: usize,
    params: &MatchParams,
) -> Result<Vec<Ranked>, IndexError> {
    if let [view] = views {
        return rank(reader, *view, k, params);
    }
    // each shape's best result and its best place in any hypothesis's ranking
    let mut best: BTreeMap<ShapeId, (Ranked, usize)> = BTreeMap::new();
    for (h, view) in views.iter().enumerate() {
        for (place, mut r) in rank(reader, *view, k, params)?.into_iter().enumerate() {
            r.hypothesis = h;
            match best.get_mut(&r.id) {
                None => {
                    best.insert(r.id, (r, place));
                }
                Some((kept, p)) => {
                    *p = (*p).min(place);
                    if r.result.score > kept.result.score {
                        *kept = r;
                    }
                }
            }
        }
    }
    let mut ranked: Vec<(Ranked, usize)> = best.into_values().collect();
    ranked.sort_by(|(a, pa), (b, pb)| {
        b.result
            .score
            .total_cmp(&a.result.score)
            .then(pa.cmp(pb))
            .then(a.id.cmp(&b.id))
    });
    ranked.truncate(k);
    Ok(ranked.into_iter().map(|(r, _)| r).collect())
}

/// Matches the candidates `by_vote` (best-voted first) part to part and returns the `k` best
/// by score (ties by shape id), in that order; a candidate's score is the same as if every
/// candidate were matched.
///
/// Best-first branch and bound over two upper bounds of a candidate's score: the matrix of
/// descriptor distances gives one ([`score_bound`]: every query part at its best similarity), the
/// assignment a tighter one ([`pairs_score`] of every assigned pair). The open candidate of highest
/// bound is taken next (a batch of a few at a time, in parallel): assigned if only its first bound
/// is known, then put back with the second; otherwise its record is read and its match finished
/// (the layout check). It stops when the highest open bound is below the `k`-th best score found,
/// so the layout check, the costliest step, runs only for candidates whose assignment can still
/// enter the top `k`.
fn match_candidates(
    reader: &IndexReader<DIM>,
    query: ShapeView,
    by_vote: &[(ShapeId, f64)],
    k: usize,
    params: &MatchParams,
    weights: &[f64],
) -> Result<Vec<Ranked>, IndexError> {
    /// A candidate as the bounds need it: its descriptors, read in place, not its record.
    struct Candidate<'r> {
        id: ShapeId,
        descriptors: std::borrow::Cow<'r, [Descriptor]>,
        d: Vec<f32>,
        bound: f64,
    }
    /// A matched candidate's record and what its view takes from it.
    struct Loaded {
        rec: std::sync::Arc<keycomp_index::ShapeRecord<DIM>>,
        areas: Vec<f32>,
        centres: Vec<[f32; 3]>,
    }
    let mq = query.descriptors.len();
    // every candidate's descriptors are read below: have the system read them all at once
    // (their records are asked for once assigned, below)
    reader.prefetch_descriptors(&by_vote.iter().map(|c| c.0).collect::<Vec<_>>());
    let candidates: Vec<Option<Candidate>> = by_vote
        .par_iter()
        .map(|&(id, _)| {
            let Some(descriptors) = reader.descriptors(id)? else {
                return Ok(None);
            };
            let d = distances(query.descriptors, &descriptors);
            let bound = score_bound(mq, descriptors.len(), &d, params, weights);
            Ok(Some(Candidate {
                id,
                descriptors,
                d,
                bound,
            }))
        })
        .collect::<Result<_, IndexError>>()?;
    let candidates: Vec<Candidate> = candidates.into_iter().flatten().collect();
    fn view<'c>(c: &'c Candidate<'_>, l: &'c Loaded, params: &MatchParams) -> ShapeView<'c> {
        ShapeView {
            descriptors: &c.descriptors,
            layout: &l.rec.layout,
            areas: &l.areas,
            centres: &l.centres,
            sample: record_sample(&l.rec, params),
        }
    }
    /// A candidate's match, and its assignment while the shortlist may still verify it.
    type Scored = (ShapeMatch, Option<Assigned>);
    /// An open candidate (`at` in `candidates`): its best bound, and its assigned pairs once
    /// known (`Some(None)`: it has none to assign).
    struct Open {
        bound: f64,
        id: ShapeId,
        at: usize,
        pairs: Option<Option<Vec<ComponentMatch>>>,
    }
    // the best first: the higher bound, then the lower id
    impl Ord for Open {
        fn cmp(&self, other: &Self) -> std::cmp::Ordering {
            self.bound
                .total_cmp(&other.bound)
                .then(other.id.cmp(&self.id))
        }
    }
    impl PartialOrd for Open {
        fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(other))
        }
    }
    impl PartialEq for Open {
        fn eq(&self, other: &Self) -> bool {
            self.cmp(other).is_eq()
        }
    }
    impl Eq for Open {}
    /// A step's outcome: a candidate assigned and open again, or matched.
    enum Step {
        Assigned(Open),
        Matched(Box<(usize, Loaded, Scored)>),
    }
    // verification runs on the shortlist only: the first stage ranks without it, and keeps
    // each assignment (the costly step) for the shortlist to finish again with verification
    let gamma = unit_weight(params.verify_weight);
    let verifying = gamma > 0.0;
    let first = MatchParams {
        verify_weight: 0.0,
        ..*params
    };
    let step = |o: Open| -> Result<Step, IndexError> {
        let c = &candidates[o.at];
        let Some(pairs) = o.pairs else {
            let pairs = pair(mq, c.descriptors.len(), &c.d, &first, weights);
            let bound = pairs
                .as_ref()
                .map_or(0.0, |m| pairs_score(mq, m, &[], &first, weights));
            return Ok(Step::Assigned(Open {
                bound: bound.min(o.bound),
                pairs: Some(pairs),
                ..o
            }));
        };
        // a record is decoded only for the candidates whose assignment can enter the top k
        let rec = reader.get(c.id)?.ok_or_else(|| IndexError::InvalidQuery {
            reason: format!("shape {} has descriptors but no record", c.id),
        })?;
        let l = Loaded {
            areas: record_areas(&rec, params),
            centres: record_centres(&rec, params),
            rec,
        };
        let v = view(c, &l, &first);
        let scored = match pairs {
            None => (ShapeMatch::none(), None),
            Some(pairs) => {
                let a = check(query, v, pairs, &first);
                let kept = verifying.then(|| a.clone());
                (finish(query, v, &c.d, &first, weights, a), kept)
            }
        };
        Ok(Step::Matched(Box::new((o.at, l, scored))))
    };
    let by_score = |ranked: &mut Vec<(usize, Loaded, Scored)>| {
        ranked.sort_by(|a, b| {
            b.2.0
                .score
                .total_cmp(&a.2.0.score)
                .then(candidates[a.0].id.cmp(&candidates[b.0].id))
        })
    };
    let k_first = if verifying {
        k.max(VERIFIED_CANDIDATES)
    } else {
        k
    };
    let batch = 2 * rayon::current_num_threads().max(1);
    let mut open: std::collections::BinaryHeap<Open> = candidates
        .iter()
        .enumerate()
        .map(|(at, c)| Open {
            bound: c.bound,
            id: c.id,
            at,
            pairs: None,
        })
        .collect();
    // (position in `candidates`, its record, its match and assignment)
    let mut ranked: Vec<(usize, Loaded, Scored)> = Vec::new();
    // the k-th best score so far, once k are matched
    let mut kth: Option<f64> = None;
    // a bound below the k-th best score (by more than rounding) cannot enter the top k
    fn can_enter(bound: f64, kth: Option<f64>) -> bool {
        kth.is_none_or(|kth| bound + 1e-9 >= kth)
    }
    loop {
        let mut work = Vec::with_capacity(batch);
        while work.len() < batch
            && open.peek().is_some_and(|o| can_enter(o.bound, kth))
            && let Some(o) = open.pop()
        {
            work.push(o);
        }
        if work.is_empty() {
            break;
        }
        let done: Vec<Step> = work
            .into_par_iter()
            .map(step)
            .collect::<Result<_, IndexError>>()?;
        let mut assigned = Vec::new();
        for s in done {
            match s {
                Step::Assigned(o) => assigned.push(o),
                Step::Matched(m) => ranked.push(*m),
            }
        }
        by_score(&mut ranked);
        kth = (ranked.len() >= k_first).then(|| ranked[k_first - 1].2.0.score);
        // a record is read when its assignment's bound can still enter the top k: have the
        // system start reading it while others are matched
        let wanted: Vec<ShapeId> = assigned
            .iter()
            .filter(|o| can_enter(o.bound, kth))
            .map(|o| o.id)
            .collect();
        reader.prefetch(&wanted);
        open.extend(assigned);
    }
    if verifying {
        // the shortlist finished again with verification; beyond it, a shape that could have
        // been verified counts as verified with fitness 0
        let shortlist = ranked.len().min(VERIFIED_CANDIDATES);
        ranked[..shortlist]
            .par_iter_mut()
            .for_each(|(i, l, (m, assigned))| {
                if let Some(a) = assigned.take() {
                    let c = &candidates[*i];
                    *m = finish(query, view(c, l, params), &c.d, params, weights, a);
                }
            });
        for (i, l, (m, _)) in &mut ranked[shortlist..] {
            if can_verify(&query, &view(&candidates[*i], l, params), params) {
                m.score *= 1.0 - gamma;
            }
        }
        by_score(&mut ranked);
    }
    Ok(ranked
        .into_iter()
        .map(|(i, l, (result, _))| Ranked {
            id: candidates[i].id,
            path: l.rec.path.clone(),
            result,
            hypothesis: 0,
        })
        .collect())
}

/// The part areas of an indexed shape as [`ShapeView::areas`] wants them: area fractions in
/// scale-free indexes (every shape has unit area there), times the shape's surface area in
/// file units ([`MatchParams::file_units`]); empty when the area check is off.
pub fn record_areas(rec: &keycomp_index::ShapeRecord<DIM>, params: &MatchParams) -> Vec<f32> {
    if params.area_tolerance <= 1.0 {
        return Vec::new();
    }
    let unit = if params.file_units {
        rec.surface_area as f32
    } else {
        1.0
    };
    rec.components
        .iter()
        .map(|c| c.area_fraction * unit)
        .collect()
}

/// The part centres of an indexed shape as [`ShapeView::centres`] wants them; empty when the
/// pose check and verification are off or the record has none (written by index format 1 or
/// 2).
pub fn record_centres(
    rec: &keycomp_index::ShapeRecord<DIM>,
    params: &MatchParams,
) -> Vec<[f32; 3]> {
    if params.pose_weight <= 0.0 && params.verify_weight <= 0.0 {
        return Vec::new();
    }
    rec.components
        .iter()
        .map(|c| c.centre)
        .collect::<Option<Vec<_>>>()
        .unwrap_or_default()
}

/// The surface sample of an indexed shape as [`ShapeView::sample`] wants it; empty when
/// verification is off (or the record has none: index formats 1 to 3).
pub fn record_sample<'a>(
    rec: &'a keycomp_index::ShapeRecord<DIM>,
    params: &MatchParams,
) -> &'a [[f32; 3]] {
    if params.verify_weight <= 0.0 {
        return &[];
    }
    &rec.sample
}

/// Candidate shapes and their votes: for each query part, the similarity
/// `max(0, 1 − d/`[`MatchParams::max_distance`]`)` of the nearest of its neighbours in each
/// shape, summed over the query's parts (a shape owning none of the neighbours is no
/// candidate).
fn votes(
    neighbours: &[Vec<keycomp_index::ComponentMatch>],
    params: &MatchParams,
) -> BTreeMap<ShapeId, f64> {
    let max_d = params.max_distance.max(f32::MIN_POSITIVE) as f64;
    let mut votes = BTreeMap::new();
    for nb in neighbours {
        let mut best: BTreeMap<ShapeId, f64> = BTreeMap::new();
        for c in nb {
            let sim = (1.0 - (c.distance_sq.max(0.0) as f64).sqrt() / max_d).max(0.0);
            let e = best.entry(c.shape).or_insert(0.0);
            *e = f64::max(*e, sim);
        }
        for (s, v) in best {
            *votes.entry(s).or_insert(0.0) += v;
        }
    }
    votes
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_index::ComponentMatch;

    fn nb(shape: u64, d: f32) -> ComponentMatch {
        ComponentMatch {
            shape: ShapeId(shape),
            component: 0,
            distance_sq: d * d,
        }
    }

    #[test]
    fn votes_sum_each_parts_best_similarity_per_shape() {
        let params = MatchParams {
            max_distance: 0.8, // similarity 1 − d/0.8
            ..MatchParams::default()
        };
        let neighbours = vec![
            // part 0: shape 1 twice (the nearer counts), shape 2 beyond the match distance
            vec![nb(1, 0.2), nb(1, 0.4), nb(2, 0.9)],
            // part 1: shape 2 near
            vec![nb(2, 0.0)],
        ];
        let v = votes(&neighbours, &params);
        assert_eq!(v.len(), 2, "every shape owning a neighbour is a candidate");
        assert!((v[&ShapeId(1)] - 0.75).abs() < 1e-6);
        assert!((v[&ShapeId(2)] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn idf_weighs_rare_parts_more() {
        let params = MatchParams {
            max_distance: 0.8, // "near": within 0.4
            ..MatchParams::default()
        };
        let common: Vec<ComponentMatch> = (0..10).map(|s| nb(s, 0.1)).collect();
        let rare = vec![nb(3, 0.1), nb(4, 0.5), nb(5, 0.6)];
        let w = idf_weights(&[common, rare], 100, &params);
        assert!((w[0] - (1.0f64 + 100.0 / 11.0).ln()).abs() < 1e-9);
        assert!((w[1] - (1.0f64 + 100.0 / 2.0).ln()).abs() < 1e-9);
        assert!(w[1] > w[0]);
    }
}
