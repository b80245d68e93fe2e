//! Part-to-part matching of two described shapes: a one-to-one assignment of key-components by
//! descriptor distance, checked for geometric consistency of the layout (DESIGN "Retrieval").
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
//! 6. Geometric verification (off by default in this crate, [`MatchParams::verify_weight`] >
//!    0; keycomp's `query`, `match` and `bench retrieval` turn it on for a query with a
//!    boundary, [`verify_weight_for`]; when both shapes give their parts' positions and a
//!    surface sample, [`ShapeView::sample`]): the query is aligned onto the target from
//!    tentative pairs of parts (each query part with its [`verify::PAIRS_PER_PART`] nearest
//!    target parts by descriptor, up to [`verify::PAIR_REACH`] times the largest distance) and
//!    refined on the surface samples ([`verify`]). Assigned pairs (step 2) whose centres land together under that alignment are kept even when the
//!    layout or size check dropped them (a scan's holes and separate pieces lengthen its
//!    geodesics, so its layout disagrees with its own source's), and the score is multiplied
//!    by `1 − γ·(1 − f)`, f the share of the query's sample within
//!    [`MatchParams::verify_tolerance`] of the target's and γ the weight.
//! 7. Score: the kept similarities, each times its query part's weight (and its pose factor),
//!    summed and divided by the sum of the weights of all query parts, in [0, 1]: 1 when every
//!    query part has an identical partner in a consistent layout (times the verification
//!    factor of step 6). Dividing by the query's
//!    parts (not the target's) lets a fragment match the whole shape it was cut from. [`match_shapes`] weighs
//!    every part 1; [`rank`] weighs a part by its inverse frequency in the index
//!    ([`idf_weights`]), so parts that many shapes have count less.
//!
//! Cost: O(m³) for m components (m is small, typically under 20), O(k²) for k matches.

mod query;
pub mod verify;

pub use query::{
    CANDIDATES_PER_COMPONENT, MATCHED_CANDIDATES, Ranked, idf_weights, rank, rank_hypotheses,
    rank_neighbours, record_areas, record_centres, record_sample,
};

use keycomp_describe::Descriptor;
use serde::{Deserialize, Serialize};

/// Parameters of [`match_shapes`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MatchParams {
    /// Descriptor distance at which similarity reaches 0 (default 0.7). Lowering it makes
    /// matching stricter. On SHREC'07 Watertight and TOSCA fragments (scale-free), 0.7 raised
    /// mAP against 0.8 on every fragment kind but Watertight scans (Watertight balls 0.607 to
    /// 0.632, TOSCA balls 0.722 to 0.797; scans 0.431 to 0.427) for whole-shape mAP 0.006
    /// lower; 0.6 and 0.65 were stricter still and mixed (BENCHMARKS.md, *Matching*).
    pub max_distance: f32,
    /// Largest factor by which two layout distances may disagree after scaling (default 1.5).
    /// Raising it tolerates more deformation and worse detections; 1 demands exact agreement.
    pub layout_tolerance: f64,
    /// Weighs each query part by its inverse frequency in the index when ranking ([`rank`]):
    /// parts with close counterparts in many shapes count less. Default false: on SHREC'07
    /// Watertight it lowered fragment NN (balls 0.670 to 0.625, plane cuts 0.875 to 0.825) for
    /// a whole-shape mAP gain of 0.012 (BENCHMARKS.md, *Ablation*).
    pub idf: bool,
    /// Largest factor by which a matched pair's part areas may disagree after scaling by the
    /// square of the layout's scale (see *Steps*); 0 turns the check off. Default 6 (a factor
    /// of about 2.4 in length, between one and two patch levels): on SHREC'07 Watertight and
    /// TOSCA fragments, tolerances 4, 6 and 9 all beat no check, 6 best overall
    /// (BENCHMARKS.md, *Size consistency*).
    pub area_tolerance: f64,
    /// Whether both shapes are measured in the same length unit
    /// ([`keycomp_describe::Units::File`]): the layout's scale is then 1 instead of an
    /// estimate, and the areas [`rank`] compares are each part's area fraction times its
    /// shape's surface area instead of the fraction alone (scale-free, where every shape has
    /// unit area). Default false.
    pub file_units: bool,
    /// How much the pose check weighs (see *Steps*), in [0, 1]; 0 turns it off. Default 0:
    /// classes of articulated shapes (an animal in several poses, a person in several
    /// poses) must be found whatever their pose, and at 0.5 FAUST's subjects, each in the
    /// same ten poses as the others, fall from mAP 0.607 to 0.349 (a shape in the query's
    /// pose ranks above the query's subject in another pose). Where the pose is part of what
    /// is sought (a fragment's exact source, rigid objects), 0.5 raised every SHREC'07
    /// Watertight row in both length modes (balls 0.890 / 0.632 to 0.925 / 0.642 NN / mAP,
    /// source first 153 to 164 of 200) and, in file units, put TOSCA fragments' exact source
    /// first for 63 instead of 50 of 108 (BENCHMARKS.md, *The pose check*).
    pub pose_weight: f64,
    /// Largest factor by which two straight-line distances between matched centres may
    /// disagree after scaling for the pose check to count the pair as agreeing (default
    /// 1.25; 1.15 and 1.4 gave about the same on TOSCA).
    pub pose_tolerance: f64,
    /// How much geometric verification weighs (step 6 of *Steps*, [`verify`]), in [0, 1]; 0
    /// turns it off. Each candidate's score is multiplied by `1 − γ·(1 − f)`, f the share of
    /// the query's surface sample that lies on the target's once aligned. Default 0 here;
    /// keycomp's `query`, `match` and `bench retrieval` use [`verify_weight_for`]: 0.5 (1 in
    /// file units) for a query with a boundary (a fragment, a scan), 0 for a closed shape.
    pub verify_weight: f64,
    /// Distance (in the target's length unit: unit area when scale-free) within which a
    /// query sample point counts as lying on the target's surface (default 0.03, about 1.4
    /// times the mean distance from a point of a unit-area surface to the nearest of 512
    /// points drawn on it). On TOSCA and SHREC'07 Watertight fragments 0.03 beat 0.04 on
    /// most rows, scale-free scans most (TOSCA NN 0.667 to 0.778); 0.02–0.06 were measured
    /// (BENCHMARKS.md, *Geometric verification*).
    pub verify_tolerance: f64,
    /// How wide verification searches for the alignment ([`verify::VerifySearch::AS_READ`]
    /// by default; [`verify::VerifySearch::RESAMPLED`] where query and shapes are resampled:
    /// [`verify_search_for`]).
    pub verify_search: verify::VerifySearch,
}

impl Default for MatchParams {
    fn default() -> Self {
        MatchParams {
            max_distance: 0.7,
            layout_tolerance: 1.5,
            idf: false,
            area_tolerance: 6.0,
            file_units: false,
            pose_weight: 0.0,
            pose_tolerance: 1.25,
            verify_weight: 0.0,
            verify_tolerance: 0.03,
            verify_search: verify::VerifySearch::AS_READ,
        }
    }
}

/// Verification's search ([`MatchParams::verify_search`]): [`verify::VerifySearch::RESAMPLED`]
/// when the query and the shapes are analysed on canonical surfaces (`resampled`), else
/// [`verify::VerifySearch::AS_READ`].
pub fn verify_search_for(resampled: bool) -> verify::VerifySearch {
    if resampled {
        verify::VerifySearch::RESAMPLED
    } else {
        verify::VerifySearch::AS_READ
    }
}

/// Verification's weight ([`MatchParams::verify_weight`]) for a query with a boundary (a
/// fragment, a scan) when none is given and the shapes are scaled to unit area each: see
/// [`verify_weight_for`].
pub const FRAGMENT_VERIFY_WEIGHT: f64 = 0.5;

/// The same in file units ([`MatchParams::file_units`]), where the alignment is rigid with no
/// scale to guess, and on canonical surfaces, where query and shape are sampled alike
/// whatever their files' tessellations: the fitness is trusted in full.
pub const FRAGMENT_VERIFY_WEIGHT_FILE_UNITS: f64 = 1.0;

/// The verification weight for a query with `boundary_vertices` vertices on its boundary:
/// `weight` when given, else for a query with a boundary [`FRAGMENT_VERIFY_WEIGHT`]
/// ([`FRAGMENT_VERIFY_WEIGHT_FILE_UNITS`] when `trusted`: file units or canonical surfaces),
/// and 0 for a closed one. A
/// fragment or a scan is a piece of one surface in one pose, and where it lies on a shape is
/// what identifies its source; a closed shape is sought by its kind, in any pose (on FAUST,
/// whose classes are subjects in ten poses, verification of whole shapes lowered NN / mAP
/// from 0.870 / 0.607 to 0.720 / 0.451: BENCHMARKS.md, *Geometric verification*).
pub fn verify_weight_for(boundary_vertices: usize, trusted: bool, weight: Option<f64>) -> f64 {
    match weight {
        Some(w) => w,
        None if boundary_vertices > 0 && trusted => FRAGMENT_VERIFY_WEIGHT_FILE_UNITS,
        None if boundary_vertices > 0 => FRAGMENT_VERIFY_WEIGHT,
        None => 0.0,
    }
}

/// Distance, in the layout's length unit, within which two straight-line distances always
/// agree in the pose check: a centre found again on a fragment may sit a few vertices away.
pub const POSE_SLACK: f64 = 0.02;

/// A shape as matching sees it: component descriptors and the `m × m` layout (row-major
/// geodesic distances between component centres, any unit).
#[derive(Debug, Clone, Copy)]
pub struct ShapeView<'a> {
    /// One descriptor per component.
    pub descriptors: &'a [Descriptor],
    /// Distances between centres, `m × m` row-major.
    pub layout: &'a [f32],
    /// Each part's area in the square of the layout's unit (or all of them times one common
    /// factor); empty: no area check.
    pub areas: &'a [f32],
    /// Each part's centre position in the layout's unit (any rigid motion of the whole
    /// shape); empty: no pose check and no verification.
    pub centres: &'a [[f32; 3]],
    /// Points on the surface, in the frame and unit of `centres` (`ShapeDescription::sample`
    /// of keycomp-describe); empty: no verification.
    pub sample: &'a [[f32; 3]],
}

impl ShapeView<'_> {
    fn dist(&self, i: usize, j: usize) -> f64 {
        let m = self.descriptors.len();
        self.layout.get(i * m + j).copied().unwrap_or(f32::NAN) as f64
    }

    /// Straight-line distance between the centres of parts `i` and `j` (NaN without centres).
    fn straight(&self, i: usize, j: usize) -> f64 {
        match (self.centres.get(i), self.centres.get(j)) {
            (Some(a), Some(b)) => (0..3)
                .map(|k| (a[k] as f64 - b[k] as f64).powi(2))
                .sum::<f64>()
                .sqrt(),
            _ => f64::NAN,
        }
    }
}

/// One matched pair of components.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ComponentMatch {
    /// Index of the query (first shape's) component.
    pub query: usize,
    /// Index of the target (second shape's) component.
    pub target: usize,
    /// Descriptor distance.
    pub distance: f32,
}

/// The result of [`match_shapes`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeMatch {
    /// Kept matches, ordered by query component.
    pub matches: Vec<ComponentMatch>,
    /// Score in [0, 1] (see the module documentation).
    pub score: f64,
    /// Estimated target/query length ratio, when three or more matches allowed an estimate.
    pub scale: Option<f64>,
    /// Matches dropped by the consistency check.
    pub rejected: usize,
    /// The pose check's agreement: of the pairs of kept matches it compared, the fraction
    /// whose straight-line distances agree; `None` when it compared none (off, no centres,
    /// or fewer than three matches).
    pub pose: Option<f64>,
    /// Geometric verification's fitness (see [`verify`]): the share of the query's surface
    /// sample on the target's surface once aligned, 0 when no alignment was found; `None`
    /// when it did not run (off, or a shape without sample or centres).
    #[serde(default)]
    pub verified: Option<f64>,
}

/// The median of `v` (the mean of the two middle values for an even count), reordering `v`.
fn median_in_place(v: &mut [f64]) -> Option<f64> {
    let n = v.len();
    if n == 0 {
        return None;
    }
    let (low, mid, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    let mid = *mid;
    Some(if n % 2 == 1 {
        mid
    } else {
        let below = low.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (below + mid)
    })
}

/// Matches the components of `query` to those of `target` (see the module documentation),
/// every query component weighing the same.
pub fn match_shapes(query: ShapeView, target: ShapeView, params: &MatchParams) -> ShapeMatch {
    match_weighted(query, target, params, &[])
}

/// [`match_shapes`] with a weight per query component (`weights[i] ≥ 0`; missing or
/// non-finite weights count 1): the assignment maximises the weighted similarity and the
/// score is the weighted mean of the kept similarities over all query components.
pub fn match_weighted(
    query: ShapeView,
    target: ShapeView,
    params: &MatchParams,
    weights: &[f64],
) -> ShapeMatch {
    let d = distances(query.descriptors, target.descriptors);
    match_distances(query, target, &d, params, weights)
}

impl ShapeMatch {
    /// No match: no pair, score 0 (a shape without parts, or a candidate left unmatched).
    pub fn none() -> Self {
        ShapeMatch {
            matches: Vec::new(),
            score: 0.0,
            scale: None,
            rejected: 0,
            pose: None,
            verified: None,
        }
    }
}

/// Whether geometric verification runs for this pair of shapes: its weight is above 0 and
/// both give their parts' centres and a surface sample (shapes of older indexes have neither).
pub(crate) fn can_verify(query: &ShapeView, target: &ShapeView, params: &MatchParams) -> bool {
    unit_weight(params.verify_weight) > 0.0
        && !query.sample.is_empty()
        && !target.sample.is_empty()
        && !query.centres.is_empty()
        && !target.centres.is_empty()
}

/// A weight clamped to [0, 1]; 0 when it is not a number.
pub(crate) fn unit_weight(w: f64) -> f64 {
    if w.is_finite() {
        w.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The weight of query part `i`: `weights[i]` when it is a finite number ≥ 0, else 1.
fn part_weight(weights: &[f64], i: usize) -> f64 {
    weights
        .get(i)
        .copied()
        .filter(|w| w.is_finite() && *w >= 0.0)
        .unwrap_or(1.0)
}

/// The sum of the query's part weights ([`part_weight`] of each of its `mq` parts): the
/// score's denominator.
fn total_weight(mq: usize, weights: &[f64]) -> f64 {
    (0..mq).map(|i| part_weight(weights, i)).sum()
}

/// The similarity of two parts at descriptor distance `dd`, `max(0, 1 − dd / d_max)` (step 1
/// of *Steps*), as the score sums it.
fn similarity(dd: f32, params: &MatchParams) -> f64 {
    let max_d = params.max_distance.max(f32::MIN_POSITIVE);
    (1.0 - (dd / max_d) as f64).max(0.0)
}

/// The score of the pairs `matches` of a query of `mq` parts: their weighted similarities,
/// match `i` scaled by `pose[i]` (1 beyond `pose`), over the query's total weight (step 7 of
/// *Steps*). With every assigned pair ([`pair`]) and no factor, it bounds the score of the
/// whole match from above: the checks only drop pairs, and the pose check and verification
/// only scale the score down.
pub(crate) fn pairs_score(
    mq: usize,
    matches: &[ComponentMatch],
    pose: &[f64],
    params: &MatchParams,
    weights: &[f64],
) -> f64 {
    let total = total_weight(mq, weights);
    if total > 0.0 {
        matches
            .iter()
            .enumerate()
            .map(|(i, m)| {
                similarity(m.distance, params)
                    * part_weight(weights, m.query)
                    * pose.get(i).copied().unwrap_or(1.0)
            })
            .sum::<f64>()
            / total
    } else {
        0.0
    }
}

/// Descriptor distances of every query part to every target part, `mq × mt` row-major.
pub(crate) fn distances(query: &[Descriptor], target: &[Descriptor]) -> Vec<f32> {
    let mut d = Vec::with_capacity(query.len() * target.len());
    for q in query {
        d.extend(
            target
                .iter()
                .map(|t| keycomp_index::squared_distance_fast(q, t).sqrt()),
        );
    }
    d
}

/// An upper bound of [`match_weighted`]'s score from its distance matrix `d`: the smaller of
/// two sums, every query part counted with its best weighted similarity to any target part, and
/// every target part with its best weighted similarity to any query part (a one-to-one
/// assignment gives each part at most that, and the layout check only drops pairs).
pub(crate) fn score_bound(
    mq: usize,
    mt: usize,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> f64 {
    let weight_of = |i: usize| part_weight(weights, i);
    let total = total_weight(mq, weights);
    if total <= 0.0 || mt == 0 {
        return 0.0;
    }
    let sim = |dd: f32| similarity(dd, params);
    let rows: f64 = (0..mq)
        .map(|i| {
            let best = d[i * mt..(i + 1) * mt]
                .iter()
                .copied()
                .fold(f32::INFINITY, f32::min);
            sim(best) * weight_of(i)
        })
        .sum();
    let mut cols = vec![0f64; mt];
    for i in 0..mq {
        let w = weight_of(i);
        for (c, &dd) in cols.iter_mut().zip(&d[i * mt..(i + 1) * mt]) {
            *c = c.max(sim(dd) * w);
        }
    }
    rows.min(cols.iter().sum::<f64>()) / total
}

/// [`match_weighted`] given the distance matrix `d` ([`distances`]).
pub(crate) fn match_distances(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> ShapeMatch {
    match assign(query, target, d, params, weights) {
        Some(assigned) => finish(query, target, d, params, weights, assigned),
        None => ShapeMatch::none(),
    }
}

/// Steps 1–4 of *Steps* (the assignment, the layout and size checks): what does not depend on
/// verification, the pose check or the score, so that a query can verify its shortlist
/// without assigning again ([`finish`]). `None` when either shape has no parts.
#[derive(Debug, Clone)]
pub(crate) struct Assigned {
    /// Every assigned pair closer than the largest distance, by query part.
    matches: Vec<ComponentMatch>,
    /// Positions in `matches` of the pairs the checks kept.
    alive: Vec<usize>,
    /// Pairs the checks dropped.
    rejected: usize,
    /// The layout's scale.
    scale: Option<f64>,
}

/// Steps 1–4 of [`match_distances`]: see [`Assigned`].
pub(crate) fn assign(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> Option<Assigned> {
    let (mq, mt) = (query.descriptors.len(), target.descriptors.len());
    let matches = pair(mq, mt, d, params, weights)?;
    Some(check(query, target, matches, params))
}

/// Steps 1–2 of [`match_distances`]: the assignment maximising the total similarity of the
/// `mq × mt` distance matrix `d`, as its pairs closer than the largest distance, by query
/// part. `None` when either shape has no parts.
pub(crate) fn pair(
    mq: usize,
    mt: usize,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> Option<Vec<ComponentMatch>> {
    let weight_of = |i: usize| part_weight(weights, i);
    if mq == 0 || mt == 0 {
        return None;
    }
    let max_d = params.max_distance.max(f32::MIN_POSITIVE);
    // similarities in units of 1e-6, whole numbers: the solver's sums are then exact, so its
    // optimum does not depend on the order of its additions
    const SCALE: f64 = 1e6;
    let weight = |i: usize, dd: f32| -> f64 {
        let w = (1.0 - dd / max_d).max(0.0) as f64 * weight_of(i);
        if w.is_finite() {
            (w * SCALE).round()
        } else {
            0.0
        }
    };
    // the solver takes rows ≤ columns without copying: put the smaller side on the rows
    let transpose = mq > mt;
    let (rows, cols) = if transpose { (mt, mq) } else { (mq, mt) };
    // costs: the similarities negated, as the solver minimises
    let mut costs = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            let (i, a) = if transpose { (c, r) } else { (r, c) };
            costs.push(-weight(i, d[i * mt + a]));
        }
    }
    // finite costs always have an assignment: an error is not expected
    let (_, assignment) = lsap::solve(rows, cols, &costs, false).ok()?;
    let mut matches: Vec<ComponentMatch> = assignment
        .iter()
        .enumerate()
        .map(|(r, &c)| if transpose { (c, r) } else { (r, c) })
        .filter(|&(i, a)| d[i * mt + a] < max_d)
        .map(|(i, a)| ComponentMatch {
            query: i,
            target: a,
            distance: d[i * mt + a],
        })
        .collect();
    matches.sort_by_key(|m| m.query);
    Some(matches)
}

/// Steps 3–4 of [`match_distances`] on the assigned pairs `matches` ([`pair`]).
pub(crate) fn check(
    query: ShapeView,
    target: ShapeView,
    matches: Vec<ComponentMatch>,
    params: &MatchParams,
) -> Assigned {
    // |ln(r / s)| > ln(T) ⇔ r / s outside [1/T, T]: compared without a logarithm per pair
    let tol = params.layout_tolerance.max(1.0);
    let mut rejected = 0;
    let mut scale = None;
    // ratios dt/dq of every pair of matches, computed once (NaN: no distance on one side)
    let k0 = matches.len();
    let mut ratios = vec![f64::NAN; k0 * k0];
    if k0 >= 3 {
        for a in 0..k0 {
            for b in a + 1..k0 {
                let (x, y) = (&matches[a], &matches[b]);
                let (dq, dt) = (
                    query.dist(x.query, y.query),
                    target.dist(x.target, y.target),
                );
                if dq > 0.0 && dt > 0.0 && dq.is_finite() && dt.is_finite() {
                    ratios[a * k0 + b] = dt / dq;
                    ratios[b * k0 + a] = dt / dq;
                }
            }
        }
    }
    // positions (in the original order) of the matches still kept
    let mut alive: Vec<usize> = (0..k0).collect();
    let mut pooled = Vec::with_capacity(k0 * k0 / 2);
    while alive.len() >= 3 {
        pooled.clear();
        for (i, &a) in alive.iter().enumerate() {
            for &b in &alive[i + 1..] {
                let r = ratios[a * k0 + b];
                if !r.is_nan() {
                    pooled.push(r);
                }
            }
        }
        let Some(mut s) = median_in_place(&mut pooled) else {
            break;
        };
        if params.file_units {
            s = 1.0;
        }
        scale = Some(s);
        // per kept match: (pairs that disagree, pairs with a distance on both sides)
        let counts: Vec<(usize, usize)> = alive
            .iter()
            .map(|&a| {
                alive
                    .iter()
                    .filter(|&&b| b != a)
                    .map(|&b| ratios[a * k0 + b])
                    .filter(|r| !r.is_nan())
                    .fold((0, 0), |(bad, all), r| {
                        let q = r / s;
                        (bad + usize::from(q > tol || q * tol < 1.0), all + 1)
                    })
            })
            .collect();
        let worst = (0..alive.len()).max_by(|&i, &j| {
            counts[i].0.cmp(&counts[j].0).then(
                matches[alive[i]]
                    .distance
                    .total_cmp(&matches[alive[j]].distance)
                    .then(j.cmp(&i)),
            )
        });
        match worst {
            Some(w) if 2 * counts[w].0 > counts[w].1 => {
                alive.remove(w);
                rejected += 1;
            }
            _ => break,
        }
    }
    // the parts' sizes must agree with the layout's scale too
    if let Some(s) = scale
        && params.area_tolerance > 1.0
        && !query.areas.is_empty()
        && !target.areas.is_empty()
    {
        let tol = params.area_tolerance;
        alive.retain(|&a| {
            let m = &matches[a];
            let (aq, at) = (
                query.areas.get(m.query).copied().unwrap_or(f32::NAN) as f64,
                target.areas.get(m.target).copied().unwrap_or(f32::NAN) as f64,
            );
            let q = at / (s * s * aq);
            let keep = !(q > tol || q * tol < 1.0);
            rejected += usize::from(!keep);
            keep
        });
    }
    Assigned {
        matches,
        alive,
        rejected,
        scale,
    }
}

/// Steps 5–7 of [`match_distances`] (verification, the pose check, the score) after
/// [`assign`].
pub(crate) fn finish(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
    assigned: Assigned,
) -> ShapeMatch {
    let Assigned {
        mut matches,
        mut alive,
        mut rejected,
        scale,
    } = assigned;
    let (mq, mt) = (query.descriptors.len(), target.descriptors.len());
    let max_d = params.max_distance.max(f32::MIN_POSITIVE);
    let k0 = matches.len();
    // geometric verification: the query aligned onto the target by its parts' centres and
    // refined on their surfaces; assigned pairs that land together under that alignment are
    // kept too, whatever the layout check said. It runs only when both shapes have centres
    // and a sample (shapes of older indexes have neither and keep their score).
    let gamma = unit_weight(params.verify_weight);
    let verifying = can_verify(&query, &target, params);
    let verified = if verifying {
        verify::fitness(
            query,
            target,
            &verify::tentative_pairs(d, mq, mt, max_d * verify::PAIR_REACH),
            params.file_units.then_some(1.0),
            params.verify_tolerance,
            params.verify_search,
        )
    } else {
        None
    };
    if let Some(v) = &verified {
        let mut kept = vec![false; k0];
        for &a in &alive {
            kept[a] = true;
        }
        for (a, m) in matches.iter().enumerate() {
            if !kept[a]
                && let (Some(q), Some(t)) =
                    (query.centres.get(m.query), target.centres.get(m.target))
                && v.agrees(q, t)
            {
                alive.push(a);
                rejected -= 1;
            }
        }
        alive.sort_unstable();
    }
    if alive.len() < k0 {
        let keep: Vec<ComponentMatch> = alive.iter().map(|&a| matches[a]).collect();
        matches = keep;
    }
    // the pose check: the fraction of a kept match's partners whose straight-line distance
    // agrees with the scaled query one
    let beta = unit_weight(params.pose_weight);
    // each kept match's pose factor; empty (every factor 1) when the check does not run
    let mut pose: Vec<f64> = Vec::new();
    let mut agreement = None;
    if scale.is_some() && beta > 0.0 && !query.centres.is_empty() && !target.centres.is_empty() {
        // straight-line distances (query, target) of every pair of kept matches that the
        // layout compares too (the whole-surface part has no place)
        let k = matches.len();
        let mut pairs: Vec<(usize, usize, f64, f64)> = Vec::new();
        for a in 0..k {
            for b in a + 1..k {
                let (x, y) = (&matches[a], &matches[b]);
                if !(query.dist(x.query, y.query) > 0.0 && target.dist(x.target, y.target) > 0.0) {
                    continue;
                }
                let (eq, et) = (
                    query.straight(x.query, y.query),
                    target.straight(x.target, y.target),
                );
                if eq > 0.0 && eq.is_finite() && et.is_finite() {
                    pairs.push((a, b, eq, et));
                }
            }
        }
        // the scale of straight lines: 1 in file units, else their median ratio (the
        // geodesic one is off on a scan, whose holes lengthen its geodesics)
        let s = if params.file_units {
            Some(1.0)
        } else {
            median_in_place(&mut pairs.iter().map(|p| p.3 / p.2).collect::<Vec<_>>())
        };
        if let Some(s) = s {
            let tol = params.pose_tolerance.max(1.0);
            let mut counts = vec![(0usize, 0usize); k];
            for &(a, b, eq, et) in &pairs {
                let eq = s * eq;
                let agree = usize::from((et - eq).abs() <= (tol - 1.0) * eq.min(et) + POSE_SLACK);
                for i in [a, b] {
                    counts[i].0 += agree;
                    counts[i].1 += 1;
                }
            }
            pose = counts
                .iter()
                .map(|&(agree, compared)| {
                    let c = if compared > 0 {
                        agree as f64 / compared as f64
                    } else {
                        1.0
                    };
                    1.0 - beta * (1.0 - c)
                })
                .collect();
            if !pairs.is_empty() {
                let agree: usize = counts.iter().map(|c| c.0).sum();
                agreement = Some(agree as f64 / (2 * pairs.len()) as f64);
            }
        }
    }
    let score = pairs_score(mq, &matches, &pose, params, weights);
    // a verification that found no alignment counts as fitness 0
    let fitness = verifying.then(|| verified.map_or(0.0, |v| v.fitness));
    let score = score * (1.0 - gamma * (1.0 - fitness.unwrap_or(1.0)));
    ShapeMatch {
        verified: fitness,
        pose: agreement,
        matches,
        score,
        scale,
        rejected,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_describe::DIM;

    fn desc(seed: usize) -> Descriptor {
        let mut d = [0f32; DIM];
        d[seed % DIM] = 1.0;
        d[(seed * 7 + 3) % DIM] += 0.5;
        d
    }

    /// Centres on a line at positions xs: layout = |xi − xj|.
    fn layout(xs: &[f32]) -> Vec<f32> {
        let m = xs.len();
        (0..m * m).map(|k| (xs[k / m] - xs[k % m]).abs()).collect()
    }

    #[test]
    fn identical_shapes_match_one_to_one_with_score_one() {
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let l = layout(&[0.0, 1.0, 2.5, 4.0, 7.0]);
        let v = ShapeView {
            descriptors: &ds,
            layout: &l,
            areas: &[],
            centres: &[],
            sample: &[],
        };
        let m = match_shapes(v, v, &MatchParams::default());
        assert_eq!(m.matches.len(), 5);
        assert!(m.matches.iter().all(|x| x.query == x.target));
        assert!((m.score - 1.0).abs() < 1e-9);
        assert_eq!(m.scale, Some(1.0));
    }

    #[test]
    fn permuted_and_scaled_target_is_found() {
        let xs = [0.0, 1.0, 2.5, 4.0, 7.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let perm = [3, 0, 4, 1, 2]; // target component t holds query component perm[t]
        let dt: Vec<Descriptor> = perm.iter().map(|&p| ds[p]).collect();
        let xt: Vec<f32> = perm.iter().map(|&p| xs[p] * 3.0).collect();
        let (lq, lt) = (layout(&xs), layout(&xt));
        let m = match_shapes(
            ShapeView {
                descriptors: &ds,
                layout: &lq,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &dt,
                layout: &lt,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert_eq!(m.matches.len(), 5);
        for x in &m.matches {
            assert_eq!(perm[x.target], x.query);
        }
        assert!((m.scale.expect("scale") - 3.0).abs() < 1e-6);
    }

    #[test]
    fn a_match_in_the_wrong_place_is_rejected() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let mut xt = xs;
        xt[4] = 40.0; // same descriptor, far away from where it should be
        let (lq, lt) = (layout(&xs), layout(&xt));
        let m = match_shapes(
            ShapeView {
                descriptors: &ds,
                layout: &lq,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &ds,
                layout: &lt,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert_eq!(m.rejected, 1);
        assert!(m.matches.iter().all(|x| x.query != 4));
        assert!((m.score - 0.8).abs() < 1e-9);
    }

    #[test]
    fn a_part_of_the_wrong_size_is_rejected() {
        // target three times as long: areas nine times as large, but part 2's is not
        let xs = [0.0, 1.0, 2.5, 4.0, 7.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let xt: Vec<f32> = xs.iter().map(|x| x * 3.0).collect();
        let (lq, lt) = (layout(&xs), layout(&xt));
        let aq = [0.1f32, 0.2, 0.05, 0.1, 0.3];
        let mut at: Vec<f32> = aq.iter().map(|a| a * 9.0).collect();
        at[2] *= 6.0;
        let params = MatchParams {
            area_tolerance: 3.0,
            ..MatchParams::default()
        };
        let run = |at: &[f32], params: &MatchParams| {
            match_shapes(
                ShapeView {
                    descriptors: &ds,
                    layout: &lq,
                    areas: &aq,
                    centres: &[],
                    sample: &[],
                },
                ShapeView {
                    descriptors: &ds,
                    layout: &lt,
                    areas: at,
                    centres: &[],
                    sample: &[],
                },
                params,
            )
        };
        let m = run(&at, &params);
        assert_eq!(m.rejected, 1);
        assert!(m.matches.iter().all(|x| x.query != 2));
        // within the tolerance, or with the check off, or without areas: kept
        at[2] = aq[2] * 9.0 * 2.5;
        assert_eq!(run(&at, &params).rejected, 0);
        at[2] = aq[2] * 9.0 * 6.0;
        let off = MatchParams {
            area_tolerance: 0.0,
            ..params
        };
        assert_eq!(run(&at, &off).rejected, 0);
        assert_eq!(run(&[], &params).rejected, 0);
    }

    #[test]
    fn a_fragment_scores_by_its_own_components() {
        let ds: Vec<Descriptor> = (0..6).map(desc).collect();
        let l = layout(&[0.0, 1.0, 2.5, 4.0, 7.0, 9.0]);
        let part: Vec<Descriptor> = ds[1..4].to_vec();
        let lp = layout(&[1.0, 2.5, 4.0]);
        let m = match_shapes(
            ShapeView {
                descriptors: &part,
                layout: &lp,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &ds,
                layout: &l,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert_eq!(m.matches.len(), 3);
        assert!((m.score - 1.0).abs() < 1e-9);
        // dissimilar descriptors do not match at all
        let far: Vec<Descriptor> = (0..3).map(|_| [5.0; DIM]).collect();
        let m = match_shapes(
            ShapeView {
                descriptors: &far,
                layout: &lp,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &ds,
                layout: &l,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert!(m.matches.is_empty());
        assert_eq!(m.score, 0.0);
    }

    #[test]
    fn pairs_without_a_distance_are_not_held_against_a_match() {
        // five parts on a line plus a "whole" part with no layout distance (-1) to the others
        let ds: Vec<Descriptor> = (0..6).map(desc).collect();
        let mut l = layout(&[0.0, 1.0, 2.5, 4.0, 7.0, 0.0]);
        for i in 0..5 {
            l[i * 6 + 5] = -1.0;
            l[5 * 6 + i] = -1.0;
        }
        let v = ShapeView {
            descriptors: &ds,
            layout: &l,
            areas: &[],
            centres: &[],
            sample: &[],
        };
        let m = match_shapes(v, v, &MatchParams::default());
        assert_eq!(m.matches.len(), 6);
        assert_eq!(m.rejected, 0);
        assert!((m.score - 1.0).abs() < 1e-9);
    }

    proptest::proptest! {
        /// The bounds the ranking prunes with are never below the score, and the assignment's
        /// is the tighter: random descriptors near each other, random layouts and weights.
        #[test]
        fn score_bound_is_an_upper_bound(
            seed in 0u64..1000,
            mq in 1usize..9,
            mt in 1usize..9,
        ) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut descs = |m: usize| -> Vec<Descriptor> {
                (0..m)
                    .map(|_| std::array::from_fn(|_| rng.random_range(0.0f32..0.12)))
                    .collect()
            };
            let (dq, dt) = (descs(mq), descs(mt));
            let mut layout = |m: usize| -> Vec<f32> {
                (0..m * m).map(|k| if k / m == k % m { 0.0 } else { rng.random_range(0.1f32..2.0) }).collect()
            };
            let (lq, lt) = (layout(mq), layout(mt));
            let weights: Vec<f64> = (0..mq).map(|_| rng.random_range(0.0..2.0)).collect();
            let params = MatchParams::default();
            let q = ShapeView { descriptors: &dq, layout: &lq, areas: &[], centres: &[], sample: &[] };
            let t = ShapeView { descriptors: &dt, layout: &lt, areas: &[], centres: &[], sample: &[] };
            let m = match_weighted(q, t, &params, &weights);
            let d = distances(&dq, &dt);
            let bound = score_bound(mq, mt, &d, &params, &weights);
            let pairs = pair(mq, mt, &d, &params, &weights).unwrap_or_default();
            let assigned = pairs_score(mq, &pairs, &[], &params, &weights);
            proptest::prop_assert!(m.score <= assigned + 1e-12, "score {} assigned {}", m.score, assigned);
            proptest::prop_assert!(assigned <= bound + 1e-12, "assigned {} bound {}", assigned, bound);
        }
    }

    #[test]
    fn weights_scale_each_query_part() {
        let ds: Vec<Descriptor> = (0..4).map(desc).collect();
        let l = layout(&[0.0, 1.0, 2.5, 4.0]);
        let target: Vec<Descriptor> = ds[..2].to_vec();
        let lt = layout(&[0.0, 1.0]);
        let (q, t) = (
            ShapeView {
                descriptors: &ds,
                layout: &l,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &target,
                layout: &lt,
                areas: &[],
                centres: &[],
                sample: &[],
            },
        );
        // parts 0 and 1 match exactly, 2 and 3 have no partner
        let plain = match_shapes(q, t, &MatchParams::default());
        assert!((plain.score - 0.5).abs() < 1e-9);
        let heavy = match_weighted(q, t, &MatchParams::default(), &[3.0, 3.0, 1.0, 1.0]);
        assert!((heavy.score - 0.75).abs() < 1e-9);
        // missing or invalid weights count 1
        let odd = match_weighted(q, t, &MatchParams::default(), &[f64::NAN]);
        assert!((odd.score - 0.5).abs() < 1e-9);
    }

    #[test]
    fn empty_shapes_give_no_match() {
        let ds: Vec<Descriptor> = (0..2).map(desc).collect();
        let l = layout(&[0.0, 1.0]);
        let e = ShapeView {
            descriptors: &[],
            layout: &[],
            areas: &[],
            centres: &[],
            sample: &[],
        };
        let v = ShapeView {
            descriptors: &ds,
            layout: &l,
            areas: &[],
            centres: &[],
            sample: &[],
        };
        assert_eq!(match_shapes(e, v, &MatchParams::default()).score, 0.0);
        assert_eq!(match_shapes(v, e, &MatchParams::default()).score, 0.0);
    }

    /// The same parts, the same geodesic layout: one target in the query's pose (scaled by
    /// 2), one with a limb bent (part 4 moved, its geodesic distances unchanged). The pose
    /// check ranks the first above the second, by a margin set by the weight, and changes
    /// nothing when it is off or when a side has no centres.
    #[test]
    fn a_bent_pose_scores_below_the_same_pose() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let lq = layout(&xs);
        let lt = layout(&xs.map(|x| 2.0 * x));
        let straight: Vec<[f32; 3]> = xs.iter().map(|&x| [x, 0.0, 0.0]).collect();
        let same: Vec<[f32; 3]> = xs.iter().map(|&x| [2.0 * x, 5.0, -1.0]).collect();
        // part 4 folded back towards part 2: still 2 from part 3, but 2 from part 2 (not 4)
        let mut bent = same.clone();
        bent[4] = [5.0, 5.0 + 3f32.sqrt(), -1.0];
        let q = ShapeView {
            descriptors: &ds,
            layout: &lq,
            areas: &[],
            centres: &straight,
            sample: &[],
        };
        let t = |c: &[[f32; 3]], params: &MatchParams| {
            match_shapes(
                q,
                ShapeView {
                    descriptors: &ds,
                    layout: &lt,
                    areas: &[],
                    centres: c,
                    sample: &[],
                },
                params,
            )
        };
        let on = MatchParams {
            pose_weight: 0.5,
            ..MatchParams::default()
        };
        let (a, b) = (t(&same, &on), t(&bent, &on));
        assert_eq!(a.pose, Some(1.0));
        assert!((a.score - 1.0).abs() < 1e-9, "{}", a.score);
        // pairs (4, 0), (4, 1), (4, 2) disagree: 14 of 20 ordered pairs agree
        assert_eq!(b.pose, Some(14.0 / 20.0));
        // parts 0–2 agree with 3 of 4, part 3 with all, part 4 with 1 of 4
        let want = (3.0 * (1.0 - 0.5 * 0.25) + 1.0 + (1.0 - 0.5 * 0.75)) / 5.0;
        assert!((b.score - want).abs() < 1e-9, "{} against {want}", b.score);
        assert!(b.score < a.score);
        // off: both score 1
        let off = MatchParams::default();
        assert!((t(&bent, &off).score - 1.0).abs() < 1e-9);
        assert_eq!(t(&bent, &off).pose, None);
        // no centres on the target: no pose check either
        assert!((t(&[], &on).score - 1.0).abs() < 1e-9);
    }
}
