//! Maximally stable components of a [`ComponentTree`]: the area-stability criterion of
//! J. Matas, O. Chum, M. Urban and T. Pajdla, "Robust wide-baseline stereo from maximally
//! stable extremal regions", *Image and Vision Computing* 22(10):761–767, 2004, on the graph
//! component trees of Litman, Bronstein & Bronstein (Computers & Graphics 35(3), 2011,
//! Section 2).
//!
//! # Criterion
//!
//! A node `C` of level `τ` and area `A(C)` is, between `τ` and `τ + Δ`, contained in its
//! highest ancestor `C⁺` whose level is `≤ τ + Δ` (the component containing `C` at threshold
//! `τ + Δ`; `C` itself if its parent appears later). Its **variation** is the relative area
//! growth over that weight interval,
//!
//! ```text
//! v(C) = (A(C⁺) − A(C)) / A(C)
//! ```
//!
//! (the one-sided form used by VLFeat's MSER; the inverse of Litman et al.'s "stability"
//! `A / ΔA`, up to the constant `Δ`). `C` is **maximally stable** when `v(C)` is a local
//! minimum along the tree: `v(C) < v(parent)` (a root has no parent and always passes) and
//! `v(C) ≤ v(child)` for every child. On a plateau of equal variations along a chain, the
//! highest node is the one selected.
//!
//! Then the usual filters ([`StableParams`]): area between `min_area` and `max_area` (fractions
//! of the total area of the graph), variation at most `max_variation`, and **duplicate
//! suppression**: of two selected nested components whose areas differ by less than a fraction
//! `min_diversity` of the larger one, only the more stable is kept (components are accepted in
//! order of increasing variation, ties by node id, and each is dropped if it is too close to an
//! already accepted one that contains it or that it contains).
//!
//! # Complexity
//!
//! Variations: one depth-first pass with the root path on a stack and a binary search on it per
//! node, `O(n log depth)`. Duplicates: `O(m²)` for `m` candidates (tens to hundreds).

use serde::{Deserialize, Serialize};

use crate::error::{MserError, Result};
use crate::tree::ComponentTree;

/// Parameters of [`maximally_stable`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StableParams {
    /// The weight interval `Δ` of the variation, in the tree's level units (> 0). Default 0.1.
    pub delta: f64,
    /// Smallest area kept, as a fraction of the total area (in `[0, 1]`). Default 0.01.
    pub min_area: f64,
    /// Largest area kept, as a fraction of the total area (in `[min_area, 1]`). Default 0.5.
    pub max_area: f64,
    /// Largest variation kept (≥ 0; `f64::INFINITY` keeps every local minimum). Default 1.
    pub max_variation: f64,
    /// Duplicate suppression: nested components whose areas differ by less than this fraction
    /// of the larger are duplicates (in `[0, 1)`; 0 keeps all). Default 0.5.
    pub min_diversity: f64,
}

impl Default for StableParams {
    fn default() -> Self {
        StableParams {
            delta: 0.1,
            min_area: 0.01,
            max_area: 0.5,
            max_variation: 1.0,
            min_diversity: 0.5,
        }
    }
}

impl StableParams {
    /// Checks every range (see the fields).
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, reason: &'static str| {
            Err(MserError::InvalidParameter {
                name,
                value: value.to_string(),
                reason,
            })
        };
        if !(self.delta > 0.0 && self.delta.is_finite()) {
            return bad("delta", self.delta, "must be a positive number");
        }
        if !(0.0..=1.0).contains(&self.min_area) {
            return bad("min_area", self.min_area, "must be in [0, 1]");
        }
        if !(self.min_area..=1.0).contains(&self.max_area) {
            return bad("max_area", self.max_area, "must be in [min_area, 1]");
        }
        if self.max_variation.is_nan() || self.max_variation < 0.0 {
            return bad("max_variation", self.max_variation, "must be ≥ 0");
        }
        if !(0.0..1.0).contains(&self.min_diversity) {
            return bad("min_diversity", self.min_diversity, "must be in [0, 1)");
        }
        Ok(())
    }
}

/// One maximally stable component: a node of the tree and its measures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StableComponent {
    /// Node id in the [`ComponentTree`].
    pub node: usize,
    /// Its level.
    pub level: f64,
    /// Its area as a fraction of the total area.
    pub area: f64,
    /// Its variation `v(C)`.
    pub variation: f64,
}

/// The variation `v(C)` of every node for interval `delta` (see the [module docs](self));
/// `+∞` for a node of zero area.
pub fn variations(tree: &ComponentTree, delta: f64) -> Vec<f64> {
    let mut out = vec![f64::INFINITY; tree.len()];
    let mut path: Vec<usize> = Vec::new();
    let mut stack: Vec<(usize, usize)> = Vec::new(); // (node, depth)
    for &r in tree.roots() {
        stack.push((r as usize, 0));
        while let Some((x, depth)) = stack.pop() {
            path.truncate(depth);
            path.push(x);
            // levels strictly decrease from path[0] (root) to path[depth] (x)
            let limit = tree.level(x) + delta;
            let i = path.partition_point(|&a| tree.level(a) > limit);
            let up = path[i.min(depth)];
            let a = tree.area(x);
            if a > 0.0 {
                out[x] = (tree.area(up) - a) / a;
            }
            for &c in tree.children(x).iter().rev() {
                stack.push((c as usize, depth + 1));
            }
        }
    }
    out
}

/// The maximally stable components of `tree` under `params` (see the [module docs](self)), in
/// order of increasing variation (ties by node id).
///
/// Errors: invalid parameters.
pub fn maximally_stable(
    tree: &ComponentTree,
    params: &StableParams,
) -> Result<Vec<StableComponent>> {
    params.validate()?;
    let var = variations(tree, params.delta);
    let total: f64 = tree.roots().iter().map(|&r| tree.area(r as usize)).sum();
    if total <= 0.0 {
        return Ok(Vec::new());
    }
    let mut candidates: Vec<StableComponent> = Vec::new();
    for x in 0..tree.len() {
        let v = var[x];
        if !v.is_finite() {
            continue;
        }
        if tree.parent(x).is_some_and(|p| v >= var[p]) {
            continue;
        }
        if tree.children(x).iter().any(|&c| var[c as usize] < v) {
            continue;
        }
        let area = tree.area(x) / total;
        if area < params.min_area || area > params.max_area || v > params.max_variation {
            continue;
        }
        candidates.push(StableComponent {
            node: x,
            level: tree.level(x),
            area,
            variation: v,
        });
    }
    candidates.sort_by(|a, b| {
        a.variation
            .total_cmp(&b.variation)
            .then(a.node.cmp(&b.node))
    });
    let mut accepted: Vec<StableComponent> = Vec::new();
    for c in candidates {
        let duplicate = accepted.iter().any(|a| {
            let (big, small) = if tree.contains(a.node, c.node) {
                (a.area, c.area)
            } else if tree.contains(c.node, a.node) {
                (c.area, a.area)
            } else {
                return false;
            };
            big > 0.0 && (big - small) / big < params.min_diversity
        });
        if !duplicate {
            accepted.push(c);
        }
    }
    Ok(accepted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::VertexId;

    /// Path 0-…-5 with f = [0, 0.1, 0.2, 0.3, 1.0, 1.1] and masses [1, 1, 1, 1, 10, 1]: the
    /// chain {0} ⊂ {0,1} ⊂ {0,1,2} ⊂ {0..3} ⊂ {0..4} ⊂ {0..5} with areas 1, 2, 3, 4, 14, 15.
    /// With Δ = 0.25 the variations are 2, 1, 1/3, 0, 1/14, 0.
    fn chain() -> ComponentTree {
        let f = [0.0, 0.1, 0.2, 0.3, 1.0, 1.1];
        let m = [1.0, 1.0, 1.0, 1.0, 10.0, 1.0];
        let e = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)];
        ComponentTree::vertex_weighted(&f, &m, &e).unwrap()
    }

    fn by_level(t: &ComponentTree, level: f64) -> usize {
        (0..t.len()).find(|&i| t.level(i) == level).unwrap()
    }

    #[test]
    fn variations_of_a_chain() {
        let t = chain();
        let v = variations(&t, 0.25);
        let want = [
            (0.0, 2.0),
            (0.1, 1.0),
            (0.2, 1.0 / 3.0),
            (0.3, 0.0),
            (1.0, 1.0 / 14.0),
            (1.1, 0.0),
        ];
        for (level, var) in want {
            let got = v[by_level(&t, level)];
            assert!((got - var).abs() < 1e-12, "level {level}: {got} vs {var}");
        }
    }

    #[test]
    fn the_plateau_before_the_jump_is_maximally_stable() {
        let t = chain();
        let all = StableParams {
            delta: 0.25,
            min_area: 0.0,
            max_area: 1.0,
            max_variation: f64::INFINITY,
            min_diversity: 0.0,
        };
        let got = maximally_stable(&t, &all).unwrap();
        let nodes: Vec<Vec<VertexId>> = got.iter().map(|s| t.sorted_vertices(s.node)).collect();
        // variation 0 for both; ties by node id (creation order: the chain node first)
        assert_eq!(nodes, vec![vec![0, 1, 2, 3], vec![0, 1, 2, 3, 4, 5]]);
        assert!((got[0].area - 4.0 / 15.0).abs() < 1e-12);
        // max_area drops the root
        let half = StableParams {
            max_area: 0.5,
            ..all
        };
        let got = maximally_stable(&t, &half).unwrap();
        assert_eq!(got.len(), 1);
        assert_eq!(t.sorted_vertices(got[0].node), vec![0, 1, 2, 3]);
        // min_area drops it too
        let big = StableParams {
            min_area: 0.3,
            ..half
        };
        assert!(maximally_stable(&t, &big).unwrap().is_empty());
        // duplicates: (15 − 4) / 15 < 0.8, so only the first accepted (the chain node) stays
        let dedup = StableParams {
            min_diversity: 0.8,
            ..all
        };
        let got = maximally_stable(&t, &dedup).unwrap();
        assert_eq!(got.len(), 1);
        assert_eq!(t.sorted_vertices(got[0].node), vec![0, 1, 2, 3]);
        // max_variation below every candidate's
        let strict = StableParams {
            max_variation: 0.0,
            ..all
        };
        assert_eq!(maximally_stable(&t, &strict).unwrap().len(), 2);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let t = chain();
        for (p, name) in [
            (
                StableParams {
                    delta: 0.0,
                    ..StableParams::default()
                },
                "delta",
            ),
            (
                StableParams {
                    min_area: 2.0,
                    ..StableParams::default()
                },
                "min_area",
            ),
            (
                StableParams {
                    max_area: 0.001,
                    ..StableParams::default()
                },
                "max_area",
            ),
            (
                StableParams {
                    max_variation: f64::NAN,
                    ..StableParams::default()
                },
                "max_variation",
            ),
            (
                StableParams {
                    min_diversity: 1.0,
                    ..StableParams::default()
                },
                "min_diversity",
            ),
        ] {
            let e = maximally_stable(&t, &p).unwrap_err().to_string();
            assert!(e.contains(name), "{e}");
        }
    }
}
