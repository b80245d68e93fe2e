//! Part-to-part matching of two described shapes: a one-to-one assignment of key-components by
//! descriptor distance, checked for geometric consistency of the layout, and the ranking of an
//! index's shapes against a query by it.
//!
//! The parts are built on the key-components of I. Sipiran and B. Bustos, "Key-components:
//! detection of salient regions on 3D meshes", The Visual Computer 29(12), 2013
//! (`keycomp_describe`). The paper detects key-components and does not match them: matching
//! and retrieval are keycomp's own, made of the published methods cited at each step below
//! (docs/method.md, *Matching* and *Geometric verification*).
//!
//! # Steps
//!
//! 1. Similarity of query component i and target component a: `w = max(0, 1 − d/d_max)` with
//!    `d` the Euclidean descriptor distance and `d_max` = [`MatchParams::max_distance`].
//! 2. The one-to-one assignment maximising the total similarity (the linear assignment problem
//!    of H. W. Kuhn, "The Hungarian method for the assignment problem", Naval Research
//!    Logistics Quarterly 2, 1955), keeping the pairs with `d < d_max`. It is solved by
//!    shortest augmenting paths (R. Jonker, A. Volgenant, "A shortest augmenting path
//!    algorithm for dense and sparse linear assignment problems", Computing 38, 1987), for
//!    rectangular matrices as in D. F. Crouse, "On implementing 2D rectangular assignment
//!    algorithms", IEEE Trans. Aerospace and Electronic Systems 52, 2016 (the `lsap` crate);
//!    similarities are whole multiples of 10⁻⁶, so the optimum is exact.
//! 3. Geometric consistency: for two kept pairs (i, a) and (j, b) the geodesic distance between
//!    the query centres, `dq(i, j)`, and between the target centres, `dt(a, b)`, must agree up to
//!    one scale factor s for the whole shape (a fragment is normalised to unit area on its own,
//!    so its lengths differ from the full shape's by an unknown factor). s is the median of
//!    `dt/dq` over all kept pairs of pairs with a distance on both sides (the whole-surface
//!    part has none), or 1 when both shapes are in the same length unit
//!    ([`MatchParams::file_units`]); a pair of pairs agrees when
//!    `|ln(dt / (s·dq))| ≤ ln(`[`MatchParams::layout_tolerance`]`)`. While some match disagrees
//!    with more than half of the others it can be compared with, the one with most
//!    disagreements (then the larger descriptor distance) is dropped. With fewer than three
//!    matches there is nothing to check.
//! 4. Size consistency ([`MatchParams::area_tolerance`], when both shapes give their parts'
//!    areas, [`ShapeView::areas`]): lengths scale by s, so areas scale by s². A kept pair
//!    (i, a) whose target area is not within that factor of `s² · area(i)` is dropped: the
//!    descriptors are scale-free, so a small patch can look like a large one, and the layout
//!    check only sees where parts are, not how large they are.
//! 5. Pose check (off by default, [`MatchParams::pose_weight`] > 0, when both shapes give
//!    their parts' positions, [`ShapeView::centres`]): the layout compares geodesic distances,
//!    which bending leaves as they are, so the same parts in another pose match as well as the
//!    source's. For two kept pairs (i, a) and (j, b) the straight-line distance between the
//!    target centres, `et`, and between the query centres times a scale s, `s·eq`, agree when
//!    `|et − s·eq| ≤ (T − 1)·min(et, s·eq) + `[`POSE_SLACK`] (T =
//!    [`MatchParams::pose_tolerance`]); s is 1 in file units, else the median of `et/eq`. Each
//!    kept pair's similarity is multiplied by `1 − β·(1 − c)`, c the fraction of the pairs it
//!    was compared with that agree and β the weight: a fragment's exact source (or a shape in
//!    the same pose) keeps its score, the same parts bent another way lose up to β of it. Only
//!    pairs the layout compares take part (not the whole-surface part).
//! 6. Geometric verification (off by default in this crate, [`MatchParams::verify_weight`] > 0;
//!    keycomp's `query`, `match` and `bench retrieval` turn it on for a query with a boundary,
//!    [`verify_weight_for`]; when both shapes give their parts' positions and a surface sample,
//!    [`ShapeView::sample`]): the query is aligned onto the target from tentative pairs of parts
//!    (each query part with its [`verify::PAIRS_PER_PART`] nearest target parts by descriptor, up
//!    to [`verify::PAIR_REACH`] times the largest distance) and refined on the surface samples
//!    ([`verify`]). Assigned pairs (step 2) whose centres land together under that alignment are
//!    kept even when the layout or size check dropped them (a scan's holes and separate pieces
//!    lengthen its geodesics, so its layout disagrees with its own source's), and the score is
//!    multiplied by `1 − γ·(1 − f)`, f the share of the query's sample within
//!    [`MatchParams::verify_tolerance`] of the target's and γ the weight.
//! 7. Score: the kept similarities, each times its query part's weight (and its pose factor),
//!    summed and divided by the sum of the weights of all query parts, in [0, 1]: 1 when every
//!    query part has an identical partner in a consistent layout (times the verification factor of
//!    step 6). Dividing by the query's parts (not the target's) lets a fragment match the whole
//!    shape it was cut from. [`match_shapes`] weighs every part 1; [`rank`] weighs a part by its
//!    inverse frequency in the index ([`idf_weights`]), so parts that many shapes have count less.
//!
//! Cost: O(m³) for m components (m is small, typically under 20), O(k²) for k matches.
//!
//! # Layout
//!
//! One module per step, in the order they run:
//!
//! - `view`: [`ShapeView`], a shape as matching sees it;
//! - `params`: [`MatchParams`] and the defaults derived from a query;
//! - `assign`: steps 1–2, similarity and the one-to-one assignment ([`ComponentMatch`]);
//! - `checks`: steps 3–5, the layout, size and pose checks;
//! - [`verify`]: step 6, geometric verification by alignment;
//! - [`refine`]: an alignment refined to the surfaces' sampling (trimmed point-to-plane ICP),
//!   for the pose of a query on a result;
//! - `score`: step 7, the score ([`ShapeMatch`]) and its upper bounds;
//! - `matching`: the steps in order for two shapes ([`match_shapes`], [`match_weighted`]);
//! - `rank`: ranking an index's shapes against a query ([`rank`], [`rank_hypotheses`]).

mod assign;
mod checks;
mod matching;
mod params;
mod rank;
pub mod refine;
mod score;
pub mod verify;
mod view;

pub use assign::ComponentMatch;
pub use checks::POSE_SLACK;
pub use matching::{match_shapes, match_weighted};
pub use params::{
    FRAGMENT_VERIFY_WEIGHT, FRAGMENT_VERIFY_WEIGHT_FILE_UNITS, MatchParams, verify_search_for,
    verify_weight_for,
};
pub use rank::{
    CANDIDATES_PER_COMPONENT, MATCHED_CANDIDATES, Ranked, idf_weights, rank, rank_hypotheses,
    rank_neighbours, record_areas, record_centres, record_sample,
};
pub use score::{ShapeMatch, align_views};
pub use verify::Alignment;
pub use view::ShapeView;
