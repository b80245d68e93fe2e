//! Adaptive clustering of the 2-D images of the keypoints: the paper's Algorithm 1 (Sipiran &
//! Bustos, Section 3.2), derived from the adaptive clustering of Leow & Li.
//!
//! The clusters aim at the paper's properties: members of a cluster lie within `R` of its
//! centroid, a new cluster is only opened more than `T` away from every centroid, and a cluster
//! keeps at least `N` members; points that fit nowhere stay unassigned (isolated keypoints).
//!
//! Steps (line numbers are Algorithm 1's). `P` starts as all points, `C` empty.
//! 1. Repeat `Iter` times (line 3):
//!    1. Assignment (lines 4–19), over the points of `P` in increasing index order: let `d` be
//!       the Euclidean distance from `p` to the nearest centroid (`2T` when `C` is empty).
//!       - `d > T`: open a new cluster `{p}` with centroid `p` and remove `p` from `P`;
//!       - `d ≤ R`: add `p` to the nearest cluster and remove it from `P`; that cluster's
//!         centroid is **not** moved now (the paper updates centroids only in step 1.2);
//!       - `R < d ≤ T`: `p` waits in `P` for a later pass.
//!    2. Update (lines 20–27), over the clusters in creation order: a cluster with at least `N`
//!       members gets its centroid set to the mean of its members; a smaller one is dissolved
//!       and its members go back into `P`.
//! 2. Return the clusters (all have ≥ `N` members, since every pass ends with an update) and
//!    the points left in `P` (unassigned).
//!
//! Readings of the pseudocode chosen here (the paper leaves them open):
//! - "dist(p, C_i)" is the Euclidean distance from `p` to the centroid of `C_i` (DESIGN.md §5;
//!   the text says "distance to the closest cluster").
//! - `P` is visited in increasing original index, and kept sorted: dissolved members re-enter
//!   `P` at their index position, not at its end. A pass visits the points that were in `P`
//!   when it started; assigning a point removes it from `P` at once.
//! - A cluster opened during a pass is a candidate "nearest cluster" for the later points of
//!   the same pass (line 8 ranges over the current `C`), with its seed point as centroid.
//! - Points once assigned are never reconsidered, unless their cluster is dissolved.
//! - Line 21 reads `|C*| ≥ N`; `C*` there stands for the loop's `C_i`.
//! - Ties for the nearest centroid go to the cluster created first; surviving clusters keep
//!   their creation order.
//! - `d = 2T` when `C` is empty only means "open a cluster"; `T > 0` is required, so it does.
//! - `Iter` passes are the paper's stopping rule. A pass that assigns no point and dissolves no
//!   cluster leaves everything as it was, so every later pass would repeat it exactly; the loop
//!   stops there, which changes no result.
//!
//! Complexity: O(Iter · |P| · |C|) distance evaluations, O(|P|) memory.
//!
//! References: I. Sipiran and B. Bustos, "Key-components: detection of salient regions on 3D
//! meshes", *The Visual Computer* 29(12), 1319–1332, 2013 (Algorithm 1); W. K. Leow and R. Li,
//! "The analysis and applications of adaptive-binning color histograms", *Computer Vision and
//! Image Understanding* 94(1–3), 67–91, 2004.

use serde::{Deserialize, Serialize};

use crate::error::ComponentsError;

/// Parameters of Algorithm 1 ([`adaptive_clustering`]). Distances are in the units of the 2-D
/// embedding, i.e. geodesic distance on the mesh normalised to unit surface area. The default is
/// the paper's KC-1 preset (see [`crate::Preset`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ClusterParams {
    /// Intra-cluster distance `R` (> 0, ≤ `t`; default 0.15): a point joins its nearest cluster
    /// when its centroid is at most this far. Raising it makes clusters wider and absorbs more
    /// waiting points; lowering it leaves more points waiting or unassigned.
    pub r: f64,
    /// Inter-cluster distance `T` (> 0, ≥ `r`; default 0.30): a point more than this far from
    /// every centroid opens a new cluster. Raising it gives fewer, more separated clusters;
    /// lowering it opens clusters more readily.
    pub t: f64,
    /// Minimum number of members `N` (default 30): smaller clusters are dissolved after each
    /// pass. Raising it keeps only denser groups of keypoints; lowering it keeps smaller ones.
    pub n_min: usize,
    /// Number of passes `Iter` (≥ 1; default 10). The paper observed convergence in 6–8.
    pub iterations: usize,
    /// Not in the paper: when set to `K_ref` (≥ 1), `N` is scaled down for point sets smaller
    /// than `K_ref`: `N_eff = clamp(round(N·K/K_ref), N_FLOOR, N)` for `K` points (see
    /// [`ClusterParams::effective_n_min`]). The paper's `N` = 30 was chosen for meshes of
    /// 20k–50k vertices, whose 1 % budget gives 200–500 keypoints; a 7k-vertex mesh gets 69
    /// keypoints, and then no group of salient points reaches 30, so it has no key-component at
    /// all. Scaling `N` with `K` keeps the required share of the keypoints instead. Default
    /// `None` (the paper's fixed `N`); the retrieval commands use it (see `keycomp index add
    /// --help`).
    pub n_reference: Option<usize>,
}

/// Smallest `N` that [`ClusterParams::n_reference`] scales down to.
pub const N_FLOOR: usize = 5;

impl Default for ClusterParams {
    fn default() -> Self {
        ClusterParams {
            r: 0.15,
            t: 0.30,
            n_min: 30,
            iterations: 10,
            n_reference: None,
        }
    }
}

impl ClusterParams {
    /// Checks that every field is in range: `0 < r ≤ t`, both finite, `n_min ≥ 1`,
    /// `iterations ≥ 1`, `n_reference ≥ 1` when set.
    pub fn validate(&self) -> Result<(), ComponentsError> {
        if !(self.r.is_finite() && self.r > 0.0) {
            return Err(ComponentsError::param(
                "cluster.r",
                self.r,
                "must be a finite distance > 0 (0.15 in the paper's KC-1)",
            ));
        }
        if !(self.t.is_finite() && self.t > 0.0) {
            return Err(ComponentsError::param(
                "cluster.t",
                self.t,
                "must be a finite distance > 0 (0.30 in the paper's KC-1)",
            ));
        }
        if self.r > self.t {
            return Err(ComponentsError::param(
                "cluster.r",
                self.r,
                "must not exceed cluster.t (the paper uses T = 2R)",
            ));
        }
        if self.n_min == 0 {
            return Err(ComponentsError::param(
                "cluster.n_min",
                0,
                "must be at least 1 keypoint (30 in the paper's KC-1)",
            ));
        }
        if self.iterations == 0 {
            return Err(ComponentsError::param(
                "cluster.iterations",
                self.iterations,
                "use at least 1 pass (the paper uses 10)",
            ));
        }
        if self.n_reference == Some(0) {
            return Err(ComponentsError::param(
                "cluster.n_reference",
                0,
                "must be at least 1 keypoint (e.g. 300), or absent for the paper's fixed N",
            ));
        }
        Ok(())
    }

    /// The minimum cluster size used for `points` points: `n_min`, or with
    /// [`ClusterParams::n_reference`] = `K_ref` and `points < K_ref`,
    /// `clamp(round(n_min·points/K_ref), N_FLOOR, n_min)` (never above `n_min`, so an `n_min`
    /// below [`N_FLOOR`] stays as it is).
    pub fn effective_n_min(&self, points: usize) -> usize {
        match self.n_reference {
            Some(k_ref) if k_ref > 0 && points < k_ref => {
                let scaled = (self.n_min as f64 * points as f64 / k_ref as f64).round() as usize;
                scaled.max(N_FLOOR).min(self.n_min)
            }
            _ => self.n_min,
        }
    }
}

/// One cluster found by [`adaptive_clustering`].
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// Indices of the member points, increasing.
    pub members: Vec<usize>,
    /// Mean of the members' positions.
    pub centroid: [f64; 2],
}

/// The result of [`adaptive_clustering`].
#[derive(Debug, Clone, PartialEq)]
pub struct Clustering {
    /// Surviving clusters, in order of creation; each has at least
    /// [`ClusterParams::effective_n_min`] members.
    pub clusters: Vec<Cluster>,
    /// Points in no cluster, increasing.
    pub unassigned: Vec<usize>,
}

/// Runs Algorithm 1 on `points` (see the module docs for the exact reading).
///
/// Errors: invalid `params`, or a point with a NaN or infinite coordinate.
pub fn adaptive_clustering(
    points: &[[f64; 2]],
    params: &ClusterParams,
) -> Result<Clustering, ComponentsError> {
    params.validate()?;
    if let Some(index) = points
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(ComponentsError::NonFinitePoint {
            what: "2-D point",
            index,
        });
    }
    let n_min = params.effective_n_min(points.len());
    let mut pending: Vec<usize> = (0..points.len()).collect();
    let mut clusters: Vec<Cluster> = Vec::new();
    let mut waiting = Vec::with_capacity(points.len());
    let mut returned = Vec::new();
    for _ in 0..params.iterations {
        // assignment
        waiting.clear();
        let mut changed = false;
        for &i in &pending {
            let p = points[i];
            let nearest = nearest_centroid(&clusters, p);
            let d = nearest.map_or(2.0 * params.t, |(_, d)| d);
            if d > params.t {
                clusters.push(Cluster {
                    members: vec![i],
                    centroid: p,
                });
                changed = true;
            } else if let Some((c, _)) = nearest.filter(|_| d <= params.r) {
                clusters[c].members.push(i);
                changed = true;
            } else {
                waiting.push(i);
            }
        }
        // update
        returned.clear();
        clusters.retain_mut(|c| {
            if c.members.len() >= n_min {
                c.members.sort_unstable();
                c.centroid = mean(points, &c.members);
                true
            } else {
                returned.extend_from_slice(&c.members);
                changed = true;
                false
            }
        });
        // P ← waiting ∪ dissolved members, sorted by index
        returned.sort_unstable();
        pending.clear();
        merge_sorted(&waiting, &returned, &mut pending);
        if !changed {
            break;
        }
    }
    Ok(Clustering {
        clusters,
        unassigned: pending,
    })
}

/// Index of and distance to the nearest centroid (first cluster on ties), `None` if none.
fn nearest_centroid(clusters: &[Cluster], p: [f64; 2]) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (c, cl) in clusters.iter().enumerate() {
        let d2 = (p[0] - cl.centroid[0]).powi(2) + (p[1] - cl.centroid[1]).powi(2);
        if best.is_none_or(|(_, b)| d2 < b) {
            best = Some((c, d2));
        }
    }
    best.map(|(c, d2)| (c, d2.sqrt()))
}

fn mean(points: &[[f64; 2]], members: &[usize]) -> [f64; 2] {
    let mut s = [0.0, 0.0];
    for &m in members {
        s[0] += points[m][0];
        s[1] += points[m][1];
    }
    let n = members.len().max(1) as f64;
    [s[0] / n, s[1] / n]
}

fn merge_sorted(a: &[usize], b: &[usize], out: &mut Vec<usize>) {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if a[i] <= b[j] {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn params(r: f64, t: f64, n_min: usize) -> ClusterParams {
        ClusterParams {
            r,
            t,
            n_min,
            iterations: 10,
            n_reference: None,
        }
    }

    #[test]
    fn n_scales_with_the_number_of_points_below_the_reference() {
        let mut p = params(0.15, 0.30, 30);
        assert_eq!(p.effective_n_min(69), 30); // the paper's fixed N
        p.n_reference = Some(300);
        assert_eq!(p.effective_n_min(300), 30);
        assert_eq!(p.effective_n_min(1000), 30);
        assert_eq!(p.effective_n_min(150), 15);
        assert_eq!(p.effective_n_min(69), 7); // 6.9 rounds to 7
        assert_eq!(p.effective_n_min(20), N_FLOOR);
        p.n_min = 3; // never raised above the user's N
        assert_eq!(p.effective_n_min(20), 3);
        p.n_reference = Some(0);
        assert!(p.validate().is_err());
    }

    #[test]
    fn a_small_point_set_keeps_its_groups_with_a_scaled_n() {
        // two tight groups of 8 points, far apart: dissolved with N = 30, kept when N is
        // scaled to 16 points with K_ref = 60 (N_eff = round(30·16/60) = 8)
        let mut pts = Vec::new();
        for g in 0..2 {
            for i in 0..8 {
                let a = i as f64 * std::f64::consts::TAU / 8.0;
                pts.push([g as f64 + 0.02 * a.cos(), 0.02 * a.sin()]);
            }
        }
        let mut p = params(0.15, 0.30, 30);
        let res = adaptive_clustering(&pts, &p).unwrap();
        assert!(res.clusters.is_empty());
        assert_eq!(res.unassigned.len(), 16);
        p.n_reference = Some(60);
        let res = adaptive_clustering(&pts, &p).unwrap();
        assert_eq!(res.clusters.len(), 2);
        assert_eq!(res.clusters[0].members, (0..8).collect::<Vec<_>>());
        assert_eq!(res.clusters[1].members, (8..16).collect::<Vec<_>>());
    }

    /// `n` points uniformly in a disc of radius `rad` around `c`.
    fn blob(c: [f64; 2], rad: f64, n: usize, rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
        (0..n)
            .map(|_| {
                let a = rng.random::<f64>() * std::f64::consts::TAU;
                let r = rad * rng.random::<f64>().sqrt();
                [c[0] + r * a.cos(), c[1] + r * a.sin()]
            })
            .collect()
    }

    #[test]
    fn two_well_separated_blobs() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut pts = blob([0.0, 0.0], 0.05, 40, &mut rng);
        pts.extend(blob([1.0, 0.0], 0.05, 35, &mut rng));
        // interleave the two blobs so the order of assignment mixes them
        let mut order: Vec<usize> = (0..75).collect();
        order.sort_by_key(|&i| (i % 5, i));
        let pts: Vec<[f64; 2]> = order.iter().map(|&i| pts[i]).collect();
        let res = adaptive_clustering(&pts, &params(0.15, 0.30, 10)).unwrap();
        assert_eq!(res.clusters.len(), 2);
        assert!(res.unassigned.is_empty());
        let expect = |lo: usize, hi: usize| -> Vec<usize> {
            (0..75).filter(|&k| (lo..hi).contains(&order[k])).collect()
        };
        let mut got: Vec<Vec<usize>> = res.clusters.iter().map(|c| c.members.clone()).collect();
        got.sort();
        let mut want = vec![expect(0, 40), expect(40, 75)];
        want.sort();
        assert_eq!(got, want);
        for c in &res.clusters {
            assert_eq!(c.centroid, mean(&pts, &c.members));
        }
    }

    #[test]
    fn small_far_blob_is_dissolved_and_left_unassigned() {
        // N = 5: a blob of 6 points survives, a far blob of N − 1 = 4 points is opened in every
        // pass and dissolved at its end, so its points end unassigned.
        let mut pts = vec![[0.0, 0.0]; 6];
        for (i, p) in pts.iter_mut().enumerate() {
            p[0] = 0.01 * i as f64;
        }
        for i in 0..4 {
            pts.push([5.0, 0.01 * i as f64]);
        }
        let res = adaptive_clustering(&pts, &params(0.15, 0.30, 5)).unwrap();
        assert_eq!(res.clusters.len(), 1);
        assert_eq!(res.clusters[0].members, vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(res.unassigned, vec![6, 7, 8, 9]);
    }

    #[test]
    fn a_point_between_r_and_t_waits_forever_when_centroids_do_not_move() {
        // Blob of 5 points centred exactly at the origin; point 5 at distance 0.2 ∈ (R, T]:
        // in pass 1 the blob's centroid is its first point (0,0) until the update, which puts
        // it at the mean (0,0) again. The point never comes within R and never exceeds T.
        let mut pts = vec![
            [0.0, 0.0],
            [0.01, 0.0],
            [-0.01, 0.0],
            [0.0, 0.01],
            [0.0, -0.01],
        ];
        pts.push([0.2, 0.0]);
        let res = adaptive_clustering(&pts, &params(0.15, 0.30, 3)).unwrap();
        assert_eq!(res.clusters.len(), 1);
        assert_eq!(res.clusters[0].members, vec![0, 1, 2, 3, 4]);
        assert_eq!(res.unassigned, vec![5]);
    }

    #[test]
    fn a_waiting_point_joins_once_the_centroid_moves() {
        // R = 0.15, T = 0.30, N = 2.
        // Pass 1: point 0 at (0,0) opens cluster A with centroid (0,0). Point 1 at (0.2,0) is at
        // 0.2 ∈ (R, T]: it waits. Point 2 at (0.1,0) is at 0.1 ≤ R: joins A, whose centroid stays
        // at (0,0) during the pass. Point 3 at (0.12,0): 0.12 ≤ R, joins A. Update: A = {0,2,3},
        // centroid (0.22/3, 0) ≈ (0.0733, 0).
        // Pass 2: point 1 is now at ≈ 0.1267 ≤ R from the centroid: it joins.
        let pts = vec![[0.0, 0.0], [0.2, 0.0], [0.1, 0.0], [0.12, 0.0]];
        let res = adaptive_clustering(&pts, &params(0.15, 0.30, 2)).unwrap();
        assert_eq!(res.clusters.len(), 1);
        assert_eq!(res.clusters[0].members, vec![0, 1, 2, 3]);
        assert!(res.unassigned.is_empty());
        assert!((res.clusters[0].centroid[0] - 0.105).abs() < 1e-12);
        // with a single pass the point is still waiting
        let one = ClusterParams {
            iterations: 1,
            ..params(0.15, 0.30, 2)
        };
        let res = adaptive_clustering(&pts, &one).unwrap();
        assert_eq!(res.clusters[0].members, vec![0, 2, 3]);
        assert_eq!(res.unassigned, vec![1]);
    }

    #[test]
    fn a_cluster_opened_mid_pass_serves_later_points_of_the_same_pass() {
        // Point 0 opens A at (0,0); point 1 at (1,0) is > T away and opens B; point 2 at
        // (1.05, 0) then joins B in the same pass (B's centroid is still (1,0)).
        let pts = vec![[0.0, 0.0], [1.0, 0.0], [1.05, 0.0]];
        let one = ClusterParams {
            iterations: 1,
            ..params(0.15, 0.30, 1)
        };
        let res = adaptive_clustering(&pts, &one).unwrap();
        assert_eq!(res.clusters.len(), 2);
        assert_eq!(res.clusters[0].members, vec![0]);
        assert_eq!(res.clusters[1].members, vec![1, 2]);
        assert_eq!(res.clusters[1].centroid, [1.025, 0.0]);
    }

    #[test]
    fn dissolved_points_are_reconsidered_in_later_passes() {
        // N = 3. Pass 1: 0 opens A at (0,0); 1 at (0.5,0) opens B; 2 at (0.05,0) joins A;
        // 3 at (0.55,0) joins B; 4 at (0.02,0) joins A. A = {0,2,4} survives (centroid
        // (0.0233,0)), B = {1,3} is dissolved. Pass 2 visits 1 then 3 (index order): 1 is at
        // 0.4767 > T from A and opens B' = {1}; 3 joins B'; B' is dissolved again. Both end
        // unassigned.
        let pts = vec![
            [0.0, 0.0],
            [0.5, 0.0],
            [0.05, 0.0],
            [0.55, 0.0],
            [0.02, 0.0],
        ];
        let res = adaptive_clustering(&pts, &params(0.15, 0.30, 3)).unwrap();
        assert_eq!(res.clusters.len(), 1);
        assert_eq!(res.clusters[0].members, vec![0, 2, 4]);
        assert_eq!(res.unassigned, vec![1, 3]);
    }

    #[test]
    fn deterministic_and_well_formed_on_random_data() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut pts = Vec::new();
        for c in 0..6 {
            let n = 5 + 7 * c;
            pts.extend(blob(
                [c as f64 * 0.5, (c % 2) as f64 * 0.4],
                0.12,
                n,
                &mut rng,
            ));
        }
        pts.extend((0..30).map(|_| [rng.random::<f64>() * 3.0, rng.random::<f64>() * 1.0]));
        let p = params(0.1, 0.2, 12);
        let a = adaptive_clustering(&pts, &p).unwrap();
        let b = adaptive_clustering(&pts, &p).unwrap();
        assert_eq!(a, b);
        // every index exactly once, every cluster ≥ N
        let mut all: Vec<usize> = a.unassigned.clone();
        for c in &a.clusters {
            assert!(c.members.len() >= 12);
            assert!(c.members.windows(2).all(|w| w[0] < w[1]));
            all.extend_from_slice(&c.members);
        }
        all.sort_unstable();
        assert_eq!(all, (0..pts.len()).collect::<Vec<_>>());
    }

    #[test]
    fn edge_cases_and_errors() {
        let res = adaptive_clustering(&[], &ClusterParams::default()).unwrap();
        assert!(res.clusters.is_empty() && res.unassigned.is_empty());
        assert!(matches!(
            adaptive_clustering(&[[f64::NAN, 0.0]], &ClusterParams::default()),
            Err(ComponentsError::NonFinitePoint { index: 0, .. })
        ));
        assert!(adaptive_clustering(&[], &params(0.3, 0.2, 1)).is_err());
        assert!(adaptive_clustering(&[], &params(0.1, 0.0, 1)).is_err());
        assert!(adaptive_clustering(&[], &params(-0.1, 0.2, 1)).is_err());
        // R = 0 and N = 0 would silently give no component: refused with the reason.
        let e = adaptive_clustering(&[], &params(0.0, 0.2, 1)).unwrap_err();
        assert!(e.to_string().contains("> 0"), "{e}");
        let e = adaptive_clustering(&[], &params(0.1, 0.2, 0)).unwrap_err();
        assert!(e.to_string().contains("at least 1 keypoint"), "{e}");
    }
}
