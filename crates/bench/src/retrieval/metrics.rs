//! Retrieval quality measures as the Princeton Shape Benchmark defines them (P. Shilane,
//! P. Min, M. Kazhdan, T. Funkhouser, "The Princeton Shape Benchmark", Shape Modeling
//! International 2004, Section 4), plus mean average precision and an interpolated
//! precision–recall curve.
//!
//! A query's result is a *ranked list* of collection shapes, best first, every shape of the
//! collection appearing once; for a whole-shape query the query itself is left out. Each entry
//! is *relevant* when it has the query's class. `R` is the number of relevant entries in the
//! list: `|C| − 1` for a whole-shape query of class `C` (PSB), `|C|` for a partial query, whose
//! source stays in the collection.
//!
//! | measure | definition (per query) |
//! |---|---|
//! | NN | 1 if the first entry is relevant, else 0 |
//! | FT (first tier) | relevant entries among the first `R`, divided by `R` (PSB: `K = |C| − 1`) |
//! | ST (second tier) | relevant entries among the first `2R`, divided by `R` |
//! | E (E-measure) | `2 / (1/P + 1/Rc)` with precision `P` and recall `Rc` of the first 32 entries (0 when none is relevant) |
//! | DCG | `DCG_1 = G_1`, `DCG_i = DCG_{i−1} + G_i / log2 i` over the whole list (`G_i` = 1 if entry i is relevant), divided by the ideal `1 + Σ_{j=2..R} 1/log2 j` |
//! | AP | `(1/R) Σ_{k relevant} P@k`, precision at each relevant rank; mAP is its mean |
//! | PR curve | precision interpolated at recall `r`: the largest `P@k` over ranks `k` whose recall is ≥ `r` (TREC convention), at `r = 0, 0.05, …, 1` |
//!
//! The collection-wide figure of each measure is the mean over queries (PSB's
//! *micro-average*); [`Summary`] also gives the mean of per-class means (*macro-average*).
//!
//! **Conventions, and where other tools differ.** The evaluation program of the SHREC'16
//! partial object retrieval track (Pratikakis et al.; queries and targets are separate sets)
//! is an example of how SHREC tools depart from PSB:
//! * *Class of size 1.* With the query left out a singleton class has `R = 0` and every measure
//!   is undefined; [`score`] returns `None` and such queries are left out of the means (and
//!   counted in [`Summary::undefined`]). Averaging a 0 for them instead would lower the means.
//! * *E over 32.* PSB fixes the retrieved set at the first 32 entries, per query. When the list
//!   is shorter than 32 (a small collection) the retrieved set here is the whole list, so `P` is
//!   the fraction of the list that is relevant; PSB, with 1,814 models, never meets that case.
//!   The SHREC'16 program instead reads P and R off the *averaged* precision–recall curve at the
//!   level nearest to 32 / (number of targets), then takes `2/(1/P + 1/R)` once.
//! * *DCG normalisation.* PSB divides by the ideal DCG, written with `|C|` in the paper; it is
//!   computed here with the `R` relevant entries actually in the list, so a perfect ranking
//!   scores exactly 1 (for whole-shape queries `R = |C| − 1`). The SHREC'16 program starts its
//!   sum at rank 2 (the first result's gain is never counted), so its values differ whenever
//!   the first result is wrong.
//! * *Tier sizes.* With the query in its own class but not in the list, PSB's first tier is
//!   `K = |C| − 1`, which is `R` here; for partial queries (the source in the collection)
//!   `K = |C| = R`, as in the SHREC'16 program, whose queries are not in the target set.
//! * *PR interpolation.* The curve here takes, at each recall level, the best precision at
//!   that recall or beyond (never increasing, TREC style); the SHREC'16 program takes the
//!   precision at the first relevant result whose recall reaches the level.

use serde::Serialize;

/// Size of the retrieved set of the E-measure (PSB).
pub const E_CUTOFF: usize = 32;

/// Recall levels of the precision–recall curve: 0, 0.05, …, 1.
pub const PR_LEVELS: usize = 21;

/// The recall value of PR level `i` (`i / 20`).
pub fn recall_level(i: usize) -> f64 {
    i as f64 / (PR_LEVELS - 1) as f64
}

/// Scores of one query (see the [module docs](self)); every value is in [0, 1].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QueryScores {
    /// Nearest neighbour.
    pub nn: f64,
    /// First tier.
    pub ft: f64,
    /// Second tier.
    pub st: f64,
    /// E-measure over the first 32.
    pub e: f64,
    /// Normalised discounted cumulative gain.
    pub dcg: f64,
    /// Average precision.
    pub ap: f64,
    /// Interpolated precision at recall `0, 0.05, …, 1` ([`recall_level`]).
    pub pr: Vec<f64>,
}

/// Scores a ranked list given as relevance flags, best first. `None` when no entry is relevant
/// (`R = 0`, a class of one shape queried by itself): every measure is undefined.
pub fn score(relevant: &[bool]) -> Option<QueryScores> {
    let r = relevant.iter().filter(|&&x| x).count();
    if r == 0 {
        return None;
    }
    let rf = r as f64;
    let hits_in = |k: usize| relevant.iter().take(k).filter(|&&x| x).count() as f64;
    let nn = if relevant[0] { 1.0 } else { 0.0 };
    let ft = hits_in(r) / rf;
    let st = hits_in(2 * r) / rf;
    let e = {
        let retrieved = E_CUTOFF.min(relevant.len());
        let hits = hits_in(retrieved);
        if hits == 0.0 {
            0.0
        } else {
            let p = hits / retrieved as f64;
            let rc = hits / rf;
            2.0 / (1.0 / p + 1.0 / rc)
        }
    };
    let gain = |i: usize| if i == 1 { 1.0 } else { 1.0 / (i as f64).log2() };
    let dcg: f64 = relevant
        .iter()
        .enumerate()
        .filter(|(_, x)| **x)
        .map(|(k, _)| gain(k + 1))
        .sum();
    let ideal: f64 = (1..=r).map(gain).sum();
    // precision and recall after each rank
    let mut hits = 0usize;
    let mut ap = 0.0;
    let mut points = Vec::with_capacity(relevant.len());
    for (k, &rel) in relevant.iter().enumerate() {
        if rel {
            hits += 1;
            ap += hits as f64 / (k + 1) as f64;
        }
        points.push((hits as f64 / rf, hits as f64 / (k + 1) as f64));
    }
    let pr = (0..PR_LEVELS)
        .map(|i| {
            let level = recall_level(i);
            points
                .iter()
                .filter(|(rc, _)| *rc >= level - 1e-12)
                .map(|&(_, p)| p)
                .fold(0.0, f64::max)
        })
        .collect();
    Some(QueryScores {
        nn,
        ft,
        st,
        e,
        dcg: dcg / ideal,
        ap: ap / rf,
        pr,
    })
}

/// Means of [`QueryScores`] over a set of queries.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Queries scored.
    pub queries: usize,
    /// Queries left out because no entry of their list is relevant.
    pub undefined: usize,
    /// Mean over queries (PSB micro-average) of each measure; `mean.ap` is the mAP.
    pub mean: QueryScores,
    /// Mean over classes of the per-class means (PSB macro-average).
    pub class_mean: QueryScores,
}

fn mean_of<'a>(scores: impl Iterator<Item = &'a QueryScores>) -> QueryScores {
    let mut m = QueryScores {
        nn: 0.0,
        ft: 0.0,
        st: 0.0,
        e: 0.0,
        dcg: 0.0,
        ap: 0.0,
        pr: vec![0.0; PR_LEVELS],
    };
    let mut n = 0usize;
    for s in scores {
        n += 1;
        m.nn += s.nn;
        m.ft += s.ft;
        m.st += s.st;
        m.e += s.e;
        m.dcg += s.dcg;
        m.ap += s.ap;
        for (a, b) in m.pr.iter_mut().zip(&s.pr) {
            *a += b;
        }
    }
    if n == 0 {
        let nan = f64::NAN;
        return QueryScores {
            nn: nan,
            ft: nan,
            st: nan,
            e: nan,
            dcg: nan,
            ap: nan,
            pr: vec![nan; PR_LEVELS],
        };
    }
    let d = n as f64;
    for v in [
        &mut m.nn, &mut m.ft, &mut m.st, &mut m.e, &mut m.dcg, &mut m.ap,
    ] {
        *v /= d;
    }
    for v in &mut m.pr {
        *v /= d;
    }
    m
}

/// Micro- and macro-averages of per-query scores; `classes[i]` is query i's class and `None`
/// marks an undefined query (see [`score`]). Classes are averaged in sorted order, so the result
/// does not depend on the query order beyond floating-point rounding.
pub fn summarize(scores: &[Option<QueryScores>], classes: &[&str]) -> Summary {
    let defined: Vec<(&QueryScores, &str)> = scores
        .iter()
        .zip(classes)
        .filter_map(|(s, c)| s.as_ref().map(|s| (s, *c)))
        .collect();
    let mut names: Vec<&str> = defined.iter().map(|(_, c)| *c).collect();
    names.sort_unstable();
    names.dedup();
    let per_class: Vec<QueryScores> = names
        .iter()
        .map(|name| mean_of(defined.iter().filter(|(_, c)| c == name).map(|(s, _)| *s)))
        .collect();
    Summary {
        queries: defined.len(),
        undefined: scores.len() - defined.len(),
        mean: mean_of(defined.iter().map(|(s, _)| *s)),
        class_mean: mean_of(per_class.iter()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    fn flags(s: &str) -> Vec<bool> {
        s.chars().map(|c| c == '1').collect()
    }

    #[test]
    fn perfect_ranking_scores_one_everywhere() {
        let s = score(&flags("11110000000")).unwrap();
        for v in [s.nn, s.ft, s.st, s.dcg, s.ap] {
            assert!(close(v, 1.0), "{s:?}");
        }
        assert!(s.pr.iter().all(|&p| close(p, 1.0)));
        // E over a list shorter than 32: P = 4/11, recall 1
        assert!(close(s.e, 2.0 / (11.0 / 4.0 + 1.0)), "{}", s.e);
    }

    #[test]
    fn perfect_ranking_in_a_long_list_gives_psb_e() {
        // 40 relevant of 100: first 32 all relevant, P = 1, recall 32/40
        let mut l = vec![true; 40];
        l.extend(vec![false; 60]);
        let s = score(&l).unwrap();
        assert!(close(s.e, 2.0 / (1.0 + 40.0 / 32.0)), "{}", s.e);
        assert!(close(s.dcg, 1.0) && close(s.ft, 1.0));
    }

    #[test]
    fn worked_example_by_hand() {
        // ranks: 1 rel, 2 not, 3 rel, 4 not, 5 not; R = 2
        let s = score(&flags("10100")).unwrap();
        assert!(close(s.nn, 1.0));
        assert!(close(s.ft, 0.5)); // first 2: one hit
        assert!(close(s.st, 1.0)); // first 4: two hits
        // E: retrieved = whole list (5), P = 2/5, recall 1 → 2/(5/2 + 1) = 4/7
        assert!(close(s.e, 4.0 / 7.0), "{}", s.e);
        // DCG = 1 + 1/log2 3; ideal = 1 + 1/log2 2 = 2
        assert!(close(s.dcg, (1.0 + 1.0 / 3f64.log2()) / 2.0), "{}", s.dcg);
        // AP = (1/1 + 2/3) / 2
        assert!(close(s.ap, 5.0 / 6.0));
        // PR: recall 0.5 first reached at rank 1 (P 1), recall 1 at rank 3 (P 2/3)
        assert!(close(s.pr[0], 1.0) && close(s.pr[10], 1.0));
        assert!(close(s.pr[11], 2.0 / 3.0) && close(s.pr[20], 2.0 / 3.0));
    }

    #[test]
    fn worst_ranking() {
        let s = score(&flags("0001")).unwrap();
        assert!(close(s.nn, 0.0) && close(s.ft, 0.0) && close(s.st, 0.0));
        assert!(close(s.ap, 0.25));
        // DCG = 1/log2 4 = 0.5, ideal 1
        assert!(close(s.dcg, 0.5));
        assert!(close(s.e, 2.0 / (4.0 + 1.0)));
        assert!(s.pr.iter().all(|&p| close(p, 0.25)));
    }

    #[test]
    fn second_tier_and_e_cutoff() {
        // R = 3; relevant at ranks 2, 5, 40 of 40
        let mut l = vec![false; 40];
        l[1] = true;
        l[4] = true;
        l[39] = true;
        let s = score(&l).unwrap();
        assert!(close(s.ft, 1.0 / 3.0)); // first 3
        assert!(close(s.st, 2.0 / 3.0)); // first 6
        // first 32: two hits, P = 2/32, recall 2/3
        let (p, r) = (2.0 / 32.0, 2.0 / 3.0);
        assert!(close(s.e, 2.0 * p * r / (p + r)));
        assert!(close(s.ap, (1.0 / 2.0 + 2.0 / 5.0 + 3.0 / 40.0) / 3.0));
        let ideal = 1.0 + 1.0 + 1.0 / 3f64.log2();
        let dcg = 1.0 + 1.0 / 5f64.log2() + 1.0 / 40f64.log2();
        assert!(close(s.dcg, dcg / ideal));
    }

    #[test]
    fn no_relevant_entry_is_undefined() {
        assert!(score(&flags("000")).is_none());
        assert!(score(&[]).is_none());
    }

    #[test]
    fn summary_micro_and_macro() {
        let a = score(&flags("10")).unwrap(); // nn 1
        let b = score(&flags("01")).unwrap(); // nn 0
        let scores = vec![Some(a.clone()), Some(a), Some(b), None];
        let s = summarize(&scores, &["x", "x", "y", "z"]);
        assert_eq!((s.queries, s.undefined), (3, 1));
        assert!(close(s.mean.nn, 2.0 / 3.0));
        assert!(close(s.class_mean.nn, 0.5));
    }

    proptest::proptest! {
        #[test]
        fn every_measure_is_in_the_unit_interval_and_monotone(bits in proptest::collection::vec(proptest::bool::ANY, 1..80)) {
            if let Some(s) = score(&bits) {
                for v in [s.nn, s.ft, s.st, s.e, s.dcg, s.ap] {
                    proptest::prop_assert!((0.0..=1.0 + 1e-12).contains(&v));
                }
                proptest::prop_assert!(s.ft <= s.st + 1e-12);
                proptest::prop_assert!(s.pr.windows(2).all(|w| w[0] + 1e-12 >= w[1]));
                // moving the first relevant entry of a non-perfect list to the front never lowers
                // a score
                let mut better = bits.clone();
                if let Some(i) = better.iter().position(|&x| x) {
                    better.remove(i);
                    better.insert(0, true);
                    let t = score(&better).unwrap();
                    proptest::prop_assert!(t.ap + 1e-12 >= s.ap && t.dcg + 1e-12 >= s.dcg && t.nn >= s.nn);
                }
            }
        }
    }
}
