//! A local-feature baseline of retrieval quality: a bag of words of Fast Point Feature
//! Histograms (R. B. Rusu, N. Blodow, M. Beetz, "Fast Point Feature Histograms (FPFH) for 3D
//! registration", IEEE International Conference on Robotics and Automation (ICRA), 2009), the
//! pipeline a practitioner builds with a point-cloud library: oriented points, one FPFH per
//! point, a k-means codebook, a tf-idf weighted histogram of words per shape, cosine
//! similarity.
//!
//! **1. Oriented points.** [`FpfhParams::points`] points drawn uniformly by area on the mesh
//! ([`AreaSampler`], ChaCha8 seeded with [`FpfhParams::seed`], so a mesh always gets the same
//! points); each takes the unit normal `(b − a) × (c − a) / ‖·‖` of its face `(a, b, c)`,
//! oriented by the mesh's winding, as given (no normal estimation, no re-orientation).
//! O(F + n log F) for F faces and n points.
//!
//! **2. Neighbourhoods.** A KD-tree (`kiddo`'s `ImmutableKdTree`) over the points; the
//! neighbours of `p` are its [`FpfhParams::max_neighbours`] nearest points within the radius
//! `r` (inclusive), nearest first, the point itself counting as one of them (the hybrid radius
//! search of Open3D's `compute_fpfh_feature` with `max_nn`); `p` itself and points at distance
//! 0 from it are then dropped. O(n log n) to build, O(n (log n + k)) for the queries, k ≤
//! `max_neighbours`.
//!
//! **3. Pair features** ([`pair_features`], Rusu 2009, Section III). For a point `p_s` with
//! normal `n_s` and a neighbour `p_t` with normal `n_t`, `d = (p_t − p_s) / ‖p_t − p_s‖`. The
//! *source* of the Darboux frame is the point whose normal makes the smaller angle with the
//! line, `acos |n·d|` (Rusu's rule that makes the triplet independent of the order of the two
//! points); on a tie the given order is kept. With the source's normal `u`, the other normal
//! `n` and `d` pointing from the source to the other point:
//! `v = u × d / ‖u × d‖`, `w = u × v` and
//!
//! * `α = v · n` ∈ [−1, 1],
//! * `φ = u · d` ∈ [−1, 1],
//! * `θ = atan2(w · n, u · n)` ∈ [−π, π].
//!
//! (The paper writes `v = u × (p_t − p_s) / ‖p_t − p_s‖`, which is not a unit vector unless
//! `u ⊥ d`; it is normalised here so that `(u, v, w)` is an orthonormal frame, as
//! implementations do.) A pair with `u ∥ d` has no frame (`v` undefined) and is skipped, as are
//! coincident points; both have probability zero for points sampled by area.
//!
//! **4. SPFH** (simplified point feature histogram) of each point: the triplets `(α, φ, θ)` to
//! each of its neighbours, each value binned into [`BINS`] = 11 equal bins over its range
//! (`floor(11 (x − lo) / (hi − lo))`, the upper end going into the last bin), the three
//! histograms concatenated in the order α, φ, θ ([`DIM`] = 33 values). Each 11-bin block is
//! scaled to sum to 100 (a percentage of the pairs; a point without neighbours has an SPFH of
//! zeros). O(n k).
//!
//! **5. FPFH** (Rusu 2009, Eq. 4): `FPFH(p) = SPFH(p) + (1/k) Σᵢ SPFH(pᵢ) / ωᵢ` over the `k`
//! neighbours `pᵢ` of `p`, with `ωᵢ = ‖p − pᵢ‖` the Euclidean distance. The weighted sum has
//! units of 1/length, so its scale relative to `SPFH(p)` would depend on the mesh's units;
//! as Open3D does, each of its three 11-bin blocks is rescaled to sum to 100, the same total
//! as the SPFH's blocks (the factor 1/k cancels in that normalisation), so both terms weigh
//! alike and the feature has no unit. Each block of the FPFH then sums to 200 (100 when the
//! point has no neighbour, or when no neighbour has one of its own). O(n k · 33). Weighting
//! by the squared distance instead, as a radius search that returns squared distances
//! invites, changed no NN or mAP of `keycomp bench retrieval` on 200 Watertight shapes by
//! more than 0.025 in one trial; this module follows the paper.
//!
//! **6. Radius.** `r = ` [`FpfhParams::radius_factor`] `· √A` ([`FpfhScale`]): `A` is the
//! mesh's own surface area ([`FpfhScale::ScaleFree`]: a fragment gets a radius from its own,
//! smaller area, and the feature does not depend on the mesh's size), or one area for every
//! mesh, the median surface area of the collection's shapes ([`FpfhScale::FileUnits`]: a
//! fragment, cut in its source's units, keeps its source's scale, which helps only when a
//! collection's shapes share one unit and size). Every mesh gets the same number of points,
//! so a fragment keeping 40 % of its source's area is 2.5 times denser; in file units, where
//! the radius stays the same, it then reaches the [`FpfhParams::max_neighbours`] cap where
//! its source does not, and its features cover a smaller region than its source's. On 200
//! Watertight shapes (3,000 points, cap 100) lifting the cap raised the file-units NN of
//! ball / plane / scan fragments from 0.575 / 0.690 / 0.450 to 0.885 / 0.920 / 0.575, and
//! left whole-shape and scale-free figures within 0.05 (`keycomp bench retrieval`, seed 0).
//!
//! **7. Codebook** ([`Codebook::fit`]): [`FpfhParams::words`] words by k-means on the
//! collection's features, Euclidean distance. When the collection has more than
//! [`FpfhParams::fit_features`] features, the codebook is fitted on that many drawn without
//! replacement (seeded), then every feature is assigned. Initialisation by k-means++ (D.
//! Arthur, S. Vassilvitskii, "k-means++: the advantages of careful seeding", ACM-SIAM SODA
//! 2007: the first centre uniform, each next one a feature drawn with probability proportional
//! to its squared distance to the nearest centre so far; one candidate per step), then Lloyd
//! iterations (S. P. Lloyd, "Least squares quantization in PCM", IEEE Transactions on
//! Information Theory 28(2), 1982: assign every feature to its nearest centre, move every
//! centre to the mean of its features; `keycomp_index::kmeans`, the k-means of the index's
//! inverted file) until no assignment changes or after
//! [`FpfhParams::max_iterations`] assignment steps. A centre left without features moves to
//! the feature farthest from its own centre. Ties go to the lower word index; the assignment
//! step runs in parallel (rayon) and the means are summed sequentially in f64, so the codebook
//! depends on the seed only, never on the number of threads. When the features have fewer
//! distinct values than words, k-means++ stops early and the codebook is smaller. O(m K · 33)
//! per iteration for m features and K words.
//!
//! **8. Histogram of words** ([`BagOfWords`]): each feature of a shape is assigned to its
//! nearest word (hard assignment), giving a count per word (`tf`); counts are weighted by
//! `idf_w = ln(N / df_w)`, with `N` the number of collection shapes and `df_w` the number of
//! them whose histogram uses word `w` ([`idf`]; a word no collection shape uses gets 0: it
//! could not make a query closer to any shape, and would only change the query's norm). A
//! query's idf is the collection's (fragments do not change it).
//!
//! **9. Similarity.** Cosine similarity `a·b / (‖a‖ ‖b‖)` of the tf-idf vectors (0 when either
//! vector is zero); shapes are ranked by decreasing similarity, i.e. increasing
//! [`cosine_distance`] `1 − cos`.

use std::num::NonZeroUsize;

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use keycomp_mesh::{Mesh, Point3, Vector3};

use keycomp_mesh::sample::AreaSampler;

use keycomp_index::kmeans::{EmptyCluster, KMeansParams, kmeans, nearest_centroid};
use keycomp_index::squared_distance_fast;

/// Bins of each of the three angle histograms.
pub const BINS: usize = 11;

/// Values of one FPFH: α, φ and θ histograms of [`BINS`] bins each, in that order.
pub const DIM: usize = 3 * BINS;

/// One FPFH (see the [module docs](self)); each 11-bin block sums to 200 (or 100, or 0).
pub type Feature = [f32; DIM];

/// Parameters of the FPFH bag of words.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FpfhParams {
    /// Points sampled per mesh (default 3,000). More points make the histograms of words less
    /// noisy and every step proportionally slower; at a fixed radius they also give each point
    /// more neighbours (up to [`FpfhParams::max_neighbours`]).
    pub points: usize,
    /// Radius of the neighbourhoods in units of `√A`, the square root of a surface area (see
    /// [`FpfhScale`]; default 0.075). Larger radii describe larger regions (more global, less
    /// sensitive to noise, less local detail); with 3,000 points, 0.075 gives about 50
    /// neighbours on a flat region.
    pub radius_factor: f64,
    /// Largest neighbourhood, the point itself included (default 100, nearest first); caps the
    /// cost where points are dense. Where the cap binds, the neighbourhood is smaller than the
    /// radius: with [`FpfhScale::FileUnits`], a fragment sampled with as many points as its
    /// source is denser and so described at a smaller effective radius (see step 6).
    pub max_neighbours: usize,
    /// Words of the codebook (default 256). More words separate finer differences of local
    /// shape but make two shapes share fewer words.
    pub words: usize,
    /// Most Lloyd assignment steps of k-means (default 50); fewer stop earlier, with a less
    /// settled codebook.
    pub max_iterations: usize,
    /// Most collection features the codebook is fitted on, drawn without replacement (default
    /// 100,000); every feature is assigned to the fitted words afterwards.
    pub fit_features: usize,
    /// Seed of the point sampling (the same for every mesh), the subsample and k-means
    /// (default 0).
    pub seed: u64,
}

impl Default for FpfhParams {
    fn default() -> FpfhParams {
        FpfhParams {
            points: 3000,
            radius_factor: 0.075,
            max_neighbours: 100,
            words: 256,
            max_iterations: 50,
            fit_features: 100_000,
            seed: 0,
        }
    }
}

impl FpfhParams {
    fn check(&self) -> Result<(), FpfhError> {
        let ok_radius = self.radius_factor > 0.0 && self.radius_factor.is_finite();
        if self.points == 0
            || self.words == 0
            || self.max_neighbours < 2
            || self.fit_features == 0
            || !ok_radius
        {
            return Err(FpfhError::InvalidParams);
        }
        Ok(())
    }
}

/// Which area sets the radius `r = radius_factor · √A` (see the [module docs](self), step 6).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FpfhScale {
    /// `A` is each mesh's own surface area.
    ScaleFree,
    /// `A` is this area (file units squared) for every mesh: the median area of the
    /// collection's shapes ([`FpfhScale::file_units`]).
    FileUnits {
        /// The area, in file units squared.
        area: f64,
    },
}

impl FpfhScale {
    /// [`FpfhScale::FileUnits`] with the median of `areas` (the mean of the two middle values
    /// for an even count; 0 for no area).
    pub fn file_units(areas: &[f64]) -> FpfhScale {
        let mut a = areas.to_vec();
        a.sort_by(f64::total_cmp);
        let n = a.len();
        let area = match n {
            0 => 0.0,
            _ if n % 2 == 1 => a[n / 2],
            _ => 0.5 * (a[n / 2 - 1] + a[n / 2]),
        };
        FpfhScale::FileUnits { area }
    }

    /// The radius for a mesh of surface area `own_area`.
    pub fn radius(&self, params: &FpfhParams, own_area: f64) -> f64 {
        let area = match *self {
            FpfhScale::ScaleFree => own_area,
            FpfhScale::FileUnits { area } => area,
        };
        params.radius_factor * area.sqrt()
    }
}

/// Why FPFH features or a bag of words cannot be computed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FpfhError {
    /// The mesh has no face of positive area to sample.
    #[error("the mesh has zero surface area: nothing to sample")]
    ZeroArea,
    /// Zero points, words or fit features, fewer than 2 neighbours, or a radius factor that is
    /// not positive.
    #[error(
        "invalid FPFH parameters: points, words and fit features must be positive, \
         max neighbours at least 2 and the radius factor above 0"
    )]
    InvalidParams,
    /// The radius is not positive and finite.
    #[error("invalid FPFH radius {0}: it must be positive and finite")]
    InvalidRadius(String),
    /// A codebook needs at least one feature.
    #[error("no features to fit a codebook on")]
    NoFeatures,
}

/// Points sampled on a mesh with the normals of their faces (step 1 of the
/// [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct OrientedPoints {
    /// Positions (file units).
    pub positions: Vec<[f64; 3]>,
    /// Unit normals, one per position.
    pub normals: Vec<Vector3<f64>>,
    /// Surface area of the mesh they were sampled on (file units squared).
    pub area: f64,
}

/// `params.points` points uniform by area on `mesh`, each with its face's unit normal.
///
/// Errors: [`FpfhError::ZeroArea`], [`FpfhError::InvalidParams`].
pub fn sample_oriented(mesh: &Mesh, params: &FpfhParams) -> Result<OrientedPoints, FpfhError> {
    params.check()?;
    let sampler = AreaSampler::new(mesh).ok_or(FpfhError::ZeroArea)?;
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let mut positions = Vec::with_capacity(params.points);
    let mut normals = Vec::with_capacity(params.points);
    for _ in 0..params.points {
        let (p, f) = sampler.sample(&mut rng);
        let [a, b, c] = mesh.triangle(f);
        // a face drawn has positive area, so its normal is defined
        let n = (b - a).cross(&(c - a)).normalize();
        positions.push([p.x, p.y, p.z]);
        normals.push(n);
    }
    Ok(OrientedPoints {
        positions,
        normals,
        area: sampler.area(),
    })
}

/// The Darboux-frame angles of a point pair (step 3 of the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairFeatures {
    /// `v · n` ∈ [−1, 1].
    pub alpha: f64,
    /// `u · d` ∈ [−1, 1].
    pub phi: f64,
    /// `atan2(w · n, u · n)` ∈ [−π, π].
    pub theta: f64,
}

/// The angles `(α, φ, θ)` between a point `ps` with unit normal `ns` and a point `pt` with unit
/// normal `nt`, or `None` when the points coincide or the source normal is parallel to the line
/// (no Darboux frame). The source is the point whose normal is closer in angle to the line, so
/// swapping the two points gives the same angles (but for exact ties).
pub fn pair_features(
    ps: &Point3<f64>,
    ns: &Vector3<f64>,
    pt: &Point3<f64>,
    nt: &Vector3<f64>,
) -> Option<PairFeatures> {
    let d = pt - ps;
    let len = d.norm();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let d = d / len;
    // acos |n·d| is smaller for the larger |n·d|
    let (u, n, d) = if ns.dot(&d).abs() >= nt.dot(&d).abs() {
        (ns, nt, d)
    } else {
        (nt, ns, -d)
    };
    let v = u.cross(&d);
    let vn = v.norm();
    if !(vn > 1e-12 && vn.is_finite()) {
        return None;
    }
    let v = v / vn;
    let w = u.cross(&v);
    Some(PairFeatures {
        alpha: v.dot(n),
        phi: u.dot(&d),
        theta: w.dot(n).atan2(u.dot(n)),
    })
}

/// The bin of `x` among [`BINS`] equal bins over `[lo, hi]` (values outside go to the end
/// bins; the upper end into the last bin).
fn bin(x: f64, lo: f64, hi: f64) -> usize {
    let b = ((x - lo) / (hi - lo) * BINS as f64).floor();
    if b >= (BINS - 1) as f64 {
        BINS - 1
    } else if b > 0.0 {
        b as usize
    } else {
        0
    }
}

/// Scales each of the three [`BINS`]-bin blocks of `h` to sum to `total` (a zero block stays
/// zero).
fn normalise_blocks(h: &mut [f64; DIM], total: f64) {
    for block in h.chunks_mut(BINS) {
        let s: f64 = block.iter().sum();
        if s > 0.0 {
            for x in block {
                *x *= total / s;
            }
        }
    }
}

/// Step 2 of the [module docs](self): for each point, its `cap` nearest points within `radius`
/// (inclusive), itself counted, as (index, distance) nearest first, then without itself and
/// without points at distance 0.
fn neighbourhoods(pos: &[[f64; 3]], radius: f64, cap: NonZeroUsize) -> Vec<Vec<(usize, f64)>> {
    if pos.is_empty() {
        return Vec::new();
    }
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(pos);
    let r2 = radius * radius;
    (0..pos.len())
        .map(|i| {
            tree.nearest_n_within::<SquaredEuclidean>(&pos[i], r2, cap, true)
                .into_iter()
                .filter(|nb| nb.item as usize != i && nb.distance > 0.0)
                .map(|nb| (nb.item as usize, nb.distance.sqrt()))
                .collect()
        })
        .collect()
}

/// The FPFH of every point of `points` at radius `radius`, with at most `max_neighbours`
/// neighbours each (the point itself included; steps 2–5 of the [module docs](self)).
///
/// Errors: [`FpfhError::InvalidRadius`] for a radius that is not positive and finite,
/// [`FpfhError::InvalidParams`] for `max_neighbours < 2`.
pub fn fpfh(
    points: &OrientedPoints,
    radius: f64,
    max_neighbours: usize,
) -> Result<Vec<Feature>, FpfhError> {
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(FpfhError::InvalidRadius(format!("{radius}")));
    }
    let cap = NonZeroUsize::new(max_neighbours)
        .filter(|k| k.get() >= 2)
        .ok_or(FpfhError::InvalidParams)?;
    let n = points.positions.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    let pos = &points.positions;
    let point = |i: usize| Point3::from(pos[i]);
    let neighbours = neighbourhoods(pos, radius, cap);
    // steps 3-4: SPFH
    let spfh: Vec<[f64; DIM]> = (0..n)
        .map(|i| {
            let mut h = [0.0; DIM];
            let (p, np) = (point(i), &points.normals[i]);
            for &(j, _) in &neighbours[i] {
                if let Some(f) = pair_features(&p, np, &point(j), &points.normals[j]) {
                    h[bin(f.alpha, -1.0, 1.0)] += 1.0;
                    h[BINS + bin(f.phi, -1.0, 1.0)] += 1.0;
                    h[2 * BINS + bin(f.theta, -std::f64::consts::PI, std::f64::consts::PI)] += 1.0;
                }
            }
            normalise_blocks(&mut h, 100.0);
            h
        })
        .collect();
    // step 5: FPFH
    Ok((0..n)
        .map(|i| {
            let mut acc = [0.0; DIM];
            for &(j, dist) in &neighbours[i] {
                for (a, s) in acc.iter_mut().zip(&spfh[j]) {
                    *a += s / dist;
                }
            }
            normalise_blocks(&mut acc, 100.0);
            let mut out = [0.0f32; DIM];
            for ((o, a), s) in out.iter_mut().zip(&acc).zip(&spfh[i]) {
                *o = (a + s) as f32;
            }
            out
        })
        .collect())
}

/// A codebook of visual words: k-means centres of FPFH features (step 7 of the
/// [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct Codebook {
    /// The words (cluster centres).
    pub words: Vec<Feature>,
}

/// At most `words` initial centres of k-means among `features` (not empty) by k-means++ (the
/// first uniform, each next one drawn with probability proportional to its squared distance to
/// the nearest centre so far), drawing from `rng`; fewer when every feature coincides with a
/// centre.
fn kmeans_pp(features: &[Feature], words: usize, rng: &mut ChaCha8Rng) -> Vec<Feature> {
    let mut centres = vec![features[rng.random_range(0..features.len())]];
    // squared distance of every feature to its nearest centre so far
    let mut nearest: Vec<f32> = features
        .par_iter()
        .map(|f| squared_distance_fast(f, &centres[0]))
        .collect();
    while centres.len() < words {
        let total: f64 = nearest.iter().map(|&d| f64::from(d)).sum();
        if !(total > 0.0 && total.is_finite()) {
            // every feature coincides with a centre: fewer distinct features than words
            break;
        }
        let target = rng.random::<f64>() * total;
        let mut acc = 0.0;
        // the last feature with positive weight, should rounding leave `acc` short
        let mut pick = nearest.iter().rposition(|&d| d > 0.0).unwrap_or(0);
        for (i, &d) in nearest.iter().enumerate() {
            acc += f64::from(d);
            if acc > target && d > 0.0 {
                pick = i;
                break;
            }
        }
        let c = features[pick];
        centres.push(c);
        nearest
            .par_iter_mut()
            .zip(features.par_iter())
            .for_each(|(d, f)| *d = d.min(squared_distance_fast(f, &c)));
    }
    centres
}

impl Codebook {
    /// k-means with k-means++ initialisation of `features` into at most `words` words, at most
    /// `max_iterations` Lloyd assignment steps, seeded by `seed` (the Lloyd iterations are
    /// `keycomp_index::kmeans`'s, an empty word moved to the feature farthest from its centre).
    ///
    /// Errors: [`FpfhError::NoFeatures`] for no features, [`FpfhError::InvalidParams`] for 0
    /// words.
    pub fn fit(
        features: &[Feature],
        words: usize,
        max_iterations: usize,
        seed: u64,
    ) -> Result<Codebook, FpfhError> {
        if features.is_empty() {
            return Err(FpfhError::NoFeatures);
        }
        if words == 0 {
            return Err(FpfhError::InvalidParams);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let start = kmeans_pp(features, words, &mut rng);
        let points: Vec<&[f32]> = features.iter().map(|f| f.as_slice()).collect();
        let params = KMeansParams {
            max_iterations,
            empty: EmptyCluster::Farthest,
        };
        let centres = kmeans(&points, DIM, start.as_flattened().to_vec(), params);
        let (words, _) = centres.as_chunks::<DIM>();
        Ok(Codebook {
            words: words.to_vec(),
        })
    }

    /// Number of words.
    pub fn len(&self) -> usize {
        self.words.len()
    }

    /// Whether the codebook has no word.
    pub fn is_empty(&self) -> bool {
        self.words.is_empty()
    }

    /// The word nearest to `f` (the lower index on a tie) and its squared distance.
    pub fn nearest(&self, f: &Feature) -> (usize, f32) {
        nearest_centroid(self.words.as_flattened(), DIM, f)
    }

    /// The number of `features` nearest to each word (hard assignment).
    pub fn counts(&self, features: &[Feature]) -> Vec<f64> {
        let mut h = vec![0.0; self.len()];
        for f in features {
            h[self.nearest(f).0] += 1.0;
        }
        h
    }
}

/// `idf_w = ln(N / df_w)` from the word counts of `N` collection shapes, `df_w` the number of
/// shapes with a positive count of word `w`; 0 for a word no shape uses.
pub fn idf(counts: &[Vec<f64>]) -> Vec<f64> {
    let words = counts.iter().map(Vec::len).max().unwrap_or(0);
    let n = counts.len() as f64;
    (0..words)
        .map(|w| {
            let df = counts
                .iter()
                .filter(|c| c.get(w).is_some_and(|&x| x > 0.0))
                .count();
            if df == 0 { 0.0 } else { (n / df as f64).ln() }
        })
        .collect()
}

/// Counts weighted by `idf` (`tf · idf`, word by word).
pub fn tf_idf(counts: &[f64], idf: &[f64]) -> Vec<f64> {
    counts.iter().zip(idf).map(|(c, w)| c * w).collect()
}

/// Cosine similarity `a·b / (‖a‖ ‖b‖)` (0 when either vector is zero).
pub fn cosine_similarity(a: &[f64], b: &[f64]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    if na > 0.0 && nb > 0.0 {
        dot / (na * nb)
    } else {
        0.0
    }
}

/// `1 − cosine_similarity(a, b)`, in [0, 2]: smaller is more similar.
pub fn cosine_distance(a: &[f64], b: &[f64]) -> f64 {
    1.0 - cosine_similarity(a, b)
}

/// A fitted FPFH bag of words: the codebook, the collection's idf, the parameters and the
/// radius rule; [`BagOfWords::describe`] gives the tf-idf vector of any mesh (steps 8–9 of the
/// [module docs](self)).
#[derive(Debug, Clone)]
pub struct BagOfWords {
    /// The codebook.
    pub codebook: Codebook,
    /// `ln(N / df)` per word, from the collection.
    pub idf: Vec<f64>,
    /// The parameters it was fitted with.
    pub params: FpfhParams,
    /// How the radius is chosen.
    pub scale: FpfhScale,
}

impl BagOfWords {
    /// Fits the codebook on the collection's features (`features[i]`: the FPFHs of shape `i`;
    /// a seeded subsample of [`FpfhParams::fit_features`] when there are more) and the idf on
    /// their word counts. Returns the model and the tf-idf vector of every collection shape.
    ///
    /// Errors: [`FpfhError::NoFeatures`], [`FpfhError::InvalidParams`].
    pub fn fit(
        features: &[Vec<Feature>],
        params: &FpfhParams,
        scale: FpfhScale,
    ) -> Result<(BagOfWords, Vec<Vec<f64>>), FpfhError> {
        params.check()?;
        let total: usize = features.iter().map(Vec::len).sum();
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed ^ 0x6b6d_6561_6e73); // "kmeans"
        let fit_on: Vec<Feature> = if total > params.fit_features {
            let mut picked =
                rand::seq::index::sample(&mut rng, total, params.fit_features).into_vec();
            picked.sort_unstable();
            let all: Vec<&Feature> = features.iter().flatten().collect();
            picked.into_iter().map(|i| *all[i]).collect()
        } else {
            features.iter().flatten().copied().collect()
        };
        let codebook = Codebook::fit(
            &fit_on,
            params.words,
            params.max_iterations,
            rng.random::<u64>(),
        )?;
        let counts: Vec<Vec<f64>> = features.par_iter().map(|f| codebook.counts(f)).collect();
        let idf = idf(&counts);
        let vectors = counts.iter().map(|c| tf_idf(c, &idf)).collect();
        Ok((
            BagOfWords {
                codebook,
                idf,
                params: *params,
                scale,
            },
            vectors,
        ))
    }

    /// The FPFHs of `mesh` with this model's parameters and radius rule (steps 1–6).
    ///
    /// Errors: [`FpfhError::ZeroArea`], [`FpfhError::InvalidRadius`].
    pub fn features(&self, mesh: &Mesh) -> Result<Vec<Feature>, FpfhError> {
        mesh_features(mesh, &self.params, self.scale)
    }

    /// The tf-idf vector of `mesh` (one value per word), to compare by [`cosine_distance`].
    ///
    /// Errors: as [`BagOfWords::features`].
    pub fn describe(&self, mesh: &Mesh) -> Result<Vec<f64>, FpfhError> {
        let f = self.features(mesh)?;
        Ok(tf_idf(&self.codebook.counts(&f), &self.idf))
    }
}

/// The FPFHs of `points` sampled on a mesh, at the radius `scale` gives for them.
///
/// Errors: [`FpfhError::InvalidRadius`] (e.g. a zero file-units area).
pub fn features_of(
    points: &OrientedPoints,
    params: &FpfhParams,
    scale: FpfhScale,
) -> Result<Vec<Feature>, FpfhError> {
    fpfh(
        points,
        scale.radius(params, points.area),
        params.max_neighbours,
    )
}

/// [`sample_oriented`] then [`features_of`].
///
/// Errors: [`FpfhError::ZeroArea`], [`FpfhError::InvalidParams`], [`FpfhError::InvalidRadius`].
pub fn mesh_features(
    mesh: &Mesh,
    params: &FpfhParams,
    scale: FpfhScale,
) -> Result<Vec<Feature>, FpfhError> {
    features_of(&sample_oriented(mesh, params)?, params, scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;
    use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_4};

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn pair_features_by_hand() {
        let o = Point3::new(0.0, 0.0, 0.0);
        let x = Point3::new(1.0, 0.0, 0.0);
        let z = Vector3::new(0.0, 0.0, 1.0);
        // normals both ⊥ d: a tie, the given order; u = z, d = x, v = z × x = y, w = z × y = −x
        let f = pair_features(&o, &z, &x, &Vector3::new(0.0, 1.0, 0.0)).unwrap();
        assert!(
            close(f.alpha, 1.0) && close(f.phi, 0.0) && close(f.theta, 0.0),
            "{f:?}"
        );
        // n_t = (1, 0, 1)/√2 is closer to the line: it is the source, d = −x;
        // v = u × d / ‖·‖ = (0, −1, 0), w = u × v = (1, 0, −1)/√2, n = z:
        // α = 0, φ = u·d = −1/√2, θ = atan2(−1/√2, 1/√2) = −π/4
        let nt = Vector3::new(1.0, 0.0, 1.0) / 2f64.sqrt();
        let f = pair_features(&o, &z, &x, &nt).unwrap();
        assert!(close(f.alpha, 0.0), "{f:?}");
        assert!(close(f.phi, -FRAC_1_SQRT_2), "{f:?}");
        assert!(close(f.theta, -FRAC_PI_4), "{f:?}");
        // the order of the two points does not matter
        assert_eq!(pair_features(&x, &nt, &o, &z), Some(f));
        // no frame: coincident points, normal along the line
        assert_eq!(pair_features(&o, &z, &o, &z), None);
        assert_eq!(pair_features(&o, &z, &Point3::new(0.0, 0.0, 2.0), &z), None);
    }

    #[test]
    fn pair_features_are_symmetric_and_in_range() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let unit = |rng: &mut ChaCha8Rng| {
            Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize()
        };
        for _ in 0..1000 {
            let (ns, nt) = (unit(&mut rng), unit(&mut rng));
            let ps = Point3::from(unit(&mut rng));
            let pt = Point3::from(unit(&mut rng) * 2.0);
            let a = pair_features(&ps, &ns, &pt, &nt).unwrap();
            let b = pair_features(&pt, &nt, &ps, &ns).unwrap();
            assert!(close(a.alpha, b.alpha) && close(a.phi, b.phi) && close(a.theta, b.theta));
            assert!(a.alpha.abs() <= 1.0 + 1e-12 && a.phi.abs() <= 1.0 + 1e-12);
            assert!(a.theta.abs() <= std::f64::consts::PI + 1e-12);
        }
    }

    #[test]
    fn neighbourhoods_match_a_linear_scan() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let pos: Vec<[f64; 3]> = (0..2000)
            .map(|_| {
                [
                    rng.random_range(0.0..1.0),
                    rng.random_range(0.0..1.0),
                    rng.random_range(0.0..0.2),
                ]
            })
            .collect();
        let d = |a: &[f64; 3], b: &[f64; 3]| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        };
        // r = 0.1 holds ~70 points on average (some beyond the cap of 40), r = 0.03 a few
        for (radius, cap) in [(0.1, 40), (0.03, 40), (0.1, 1000)] {
            let got = neighbourhoods(&pos, radius, NonZeroUsize::new(cap).unwrap());
            for (i, p) in pos.iter().enumerate() {
                let mut all: Vec<(usize, f64)> = pos
                    .iter()
                    .enumerate()
                    .map(|(j, q)| (j, d(p, q)))
                    .filter(|&(_, dist)| dist <= radius)
                    .collect();
                all.sort_by(|a, b| a.1.total_cmp(&b.1));
                // the cap counts the point itself (first, at distance 0)
                all.truncate(cap);
                all.retain(|&(j, dist)| j != i && dist > 0.0);
                let ids = |v: &[(usize, f64)]| {
                    let mut ids: Vec<usize> = v.iter().map(|x| x.0).collect();
                    ids.sort_unstable();
                    ids
                };
                assert_eq!(ids(&got[i]), ids(&all), "point {i}, r {radius}, cap {cap}");
                assert!(got[i].windows(2).all(|w| w[0].1 <= w[1].1));
                for (&(_, a), &(_, b)) in got[i].iter().zip(&all) {
                    assert!((a - b).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn bins_cover_the_ranges() {
        assert_eq!(bin(-1.0, -1.0, 1.0), 0);
        assert_eq!(bin(0.0, -1.0, 1.0), 5);
        assert_eq!(bin(1.0, -1.0, 1.0), 10);
        assert_eq!(bin(-1.0 + 2.0 / 11.0 + 1e-9, -1.0, 1.0), 1);
        assert_eq!(bin(f64::NAN, -1.0, 1.0), 0);
    }

    /// Points on a grid of the plane z = 0, normals +z.
    fn plane(n: usize, step: f64) -> OrientedPoints {
        let mut positions = Vec::new();
        for i in 0..n {
            for j in 0..n {
                positions.push([i as f64 * step, j as f64 * step, 0.0]);
            }
        }
        OrientedPoints {
            normals: vec![Vector3::new(0.0, 0.0, 1.0); positions.len()],
            positions,
            area: 1.0,
        }
    }

    #[test]
    fn a_plane_puts_everything_in_the_middle_bins() {
        // every pair: d ⊥ u = n, so α = v·n = 0, φ = u·d = 0, θ = atan2(0, 1) = 0: the middle
        // bin (5) of each block, 100 % from the SPFH and 100 % from the neighbours
        let pts = plane(20, 0.1);
        let feats = fpfh(&pts, 0.35, 100).unwrap();
        assert_eq!(feats.len(), 400);
        for f in &feats {
            for (k, &x) in f.iter().enumerate() {
                let expect = if k % BINS == 5 { 200.0 } else { 0.0 };
                assert!((x - expect).abs() < 1e-3, "bin {k}: {x}");
            }
        }
        // a radius below the grid step: no neighbour, all zeros
        let lonely = fpfh(&pts, 0.05, 100).unwrap();
        assert!(lonely.iter().all(|f| f.iter().all(|&x| x == 0.0)));
    }

    #[test]
    fn features_are_invariant_to_rigid_motion() {
        let params = FpfhParams {
            points: 1500,
            ..FpfhParams::default()
        };
        let m = synth::protrusion_sphere(3, 0.5, 0.4);
        let mut moved = m.clone();
        // rotate by 0.7 rad about (1, 2, 2)/3, translate
        let rot = nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 2.0)),
            0.7,
        );
        for p in &mut moved.positions {
            *p = rot * *p + Vector3::new(3.0, -1.0, 0.25);
        }
        for scale in [FpfhScale::ScaleFree, FpfhScale::FileUnits { area: 4.0 }] {
            let a = mesh_features(&m, &params, scale).unwrap();
            let b = mesh_features(&moved, &params, scale).unwrap();
            assert_eq!(a.len(), 1500);
            // the same faces and barycentric coordinates are drawn; only rounding differs
            // (a value on a bin edge or a neighbour at exactly r could flip, rarely)
            let diff: f64 = a
                .iter()
                .zip(&b)
                .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| f64::from((p - q).abs())))
                .sum();
            let total: f64 = a.iter().flatten().map(|&x| f64::from(x)).sum();
            assert!(total > 0.0);
            assert!(diff / total < 1e-3, "relative L1 change {}", diff / total);
        }
    }

    #[test]
    fn scale_free_features_do_not_depend_on_size() {
        let params = FpfhParams {
            points: 1000,
            ..FpfhParams::default()
        };
        let m = synth::torus(1.0, 0.3, 48, 16);
        let mut big = m.clone();
        for p in &mut big.positions {
            *p = Point3::from(p.coords * 7.5);
        }
        let a = mesh_features(&m, &params, FpfhScale::ScaleFree).unwrap();
        let b = mesh_features(&big, &params, FpfhScale::ScaleFree).unwrap();
        let diff: f32 = a
            .iter()
            .zip(&b)
            .map(|(x, y)| squared_distance_fast(x, y).sqrt())
            .sum();
        assert!(diff / (a.len() as f32) < 0.5, "{diff}");
        // while a fixed radius sees more neighbours on the larger copy: different features
        let units = FpfhScale::FileUnits { area: m_area(&m) };
        let c = mesh_features(&big, &params, units).unwrap();
        let diff: f32 = a
            .iter()
            .zip(&c)
            .map(|(x, y)| squared_distance_fast(x, y).sqrt())
            .sum();
        assert!(diff / (a.len() as f32) > 5.0, "{diff}");
    }

    fn m_area(m: &Mesh) -> f64 {
        keycomp_mesh::geometry::total_area(m)
    }

    #[test]
    fn radius_rules() {
        let p = FpfhParams::default();
        assert!(close(FpfhScale::ScaleFree.radius(&p, 4.0), 0.15));
        let units = FpfhScale::file_units(&[9.0, 1.0, 100.0, 4.0]);
        assert_eq!(units, FpfhScale::FileUnits { area: 6.5 });
        assert!(close(units.radius(&p, 1e6), 0.075 * 6.5f64.sqrt()));
        assert_eq!(
            FpfhScale::file_units(&[3.0, 1.0, 2.0]),
            FpfhScale::FileUnits { area: 2.0 }
        );
    }

    /// Features near one of four well separated centres.
    fn clustered(per: usize, seed: u64) -> (Vec<Feature>, Vec<usize>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut feats = Vec::new();
        let mut truth = Vec::new();
        for i in 0..per * 4 {
            let c = i % 4;
            let mut f = [0.0f32; DIM];
            for (k, x) in f.iter_mut().enumerate() {
                let centre = if k % 4 == c { 100.0 } else { 0.0 };
                *x = centre + rng.random_range(-5.0..5.0);
            }
            feats.push(f);
            truth.push(c);
        }
        (feats, truth)
    }

    #[test]
    fn kmeans_recovers_separated_clusters() {
        let (feats, truth) = clustered(250, 1);
        let book = Codebook::fit(&feats, 4, 50, 7).unwrap();
        assert_eq!(book.len(), 4);
        let labels: Vec<usize> = feats.iter().map(|f| book.nearest(f).0).collect();
        // one word per cluster and one cluster per word
        for c in 0..4 {
            let words: std::collections::BTreeSet<usize> = labels
                .iter()
                .zip(&truth)
                .filter(|(_, t)| **t == c)
                .map(|(l, _)| *l)
                .collect();
            assert_eq!(words.len(), 1, "cluster {c} split over {words:?}");
        }
        let distinct: std::collections::BTreeSet<usize> = labels.iter().copied().collect();
        assert_eq!(distinct.len(), 4);
        // each word is its cluster's mean: within the noise of the true centre
        for w in &book.words {
            let c = (0..4).find(|&c| w[c] > 50.0).unwrap();
            for (k, &x) in w.iter().enumerate() {
                let centre = if k % 4 == c { 100.0 } else { 0.0 };
                assert!((x - centre).abs() < 1.0, "{x} vs {centre}");
            }
        }
        // deterministic for a seed
        assert_eq!(book, Codebook::fit(&feats, 4, 50, 7).unwrap());
        // deterministic for any number of threads
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        assert_eq!(
            book,
            pool.install(|| Codebook::fit(&feats, 4, 50, 7).unwrap())
        );
    }

    /// Lloyd's iterations stop when the assignment no longer changes: every word is then the
    /// mean (summed in f64) of the features nearest to it.
    #[test]
    fn a_settled_codebook_is_the_mean_of_its_features() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let feats: Vec<Feature> = (0..600)
            .map(|_| std::array::from_fn(|_| rng.random_range(0.0f32..200.0)))
            .collect();
        let book = Codebook::fit(&feats, 12, 1000, 3).unwrap();
        let mut sums = vec![[0.0f64; DIM]; book.len()];
        let mut counts = vec![0usize; book.len()];
        for f in &feats {
            let w = book.nearest(f).0;
            counts[w] += 1;
            for (s, x) in sums[w].iter_mut().zip(f) {
                *s += f64::from(*x);
            }
        }
        for (w, word) in book.words.iter().enumerate() {
            assert!(counts[w] > 0, "word {w} has no feature");
            for (x, s) in word.iter().zip(&sums[w]) {
                assert_eq!(*x, (s / counts[w] as f64) as f32, "word {w}");
            }
        }
    }

    #[test]
    fn kmeans_with_more_words_than_distinct_features() {
        let f = [[1.0f32; DIM], [2.0f32; DIM]];
        let feats: Vec<Feature> = (0..10).map(|i| f[i % 2]).collect();
        let book = Codebook::fit(&feats, 5, 50, 0).unwrap();
        assert_eq!(book.len(), 2);
        assert_eq!(book.counts(&feats).iter().sum::<f64>(), 10.0);
        assert_eq!(Codebook::fit(&[], 5, 50, 0), Err(FpfhError::NoFeatures));
    }

    #[test]
    fn tf_idf_and_cosine_by_hand() {
        // word 0 in A only, word 1 in B only, word 2 in all three shapes:
        // idf = (ln 3, ln 3, 0)
        let counts = vec![
            vec![1.0, 0.0, 1.0],
            vec![0.0, 2.0, 1.0],
            vec![0.0, 0.0, 3.0],
        ];
        let w = idf(&counts);
        let l3 = 3f64.ln();
        assert!(
            close(w[0], l3) && close(w[1], l3) && close(w[2], 0.0),
            "{w:?}"
        );
        let v: Vec<Vec<f64>> = counts.iter().map(|c| tf_idf(c, &w)).collect();
        assert_eq!(v[0], [l3, 0.0, 0.0]);
        assert_eq!(v[1], [0.0, 2.0 * l3, 0.0]);
        // the query (2, 1, 5) weighs (2 ln 3, ln 3, 0):
        // cos to A = 2/√5, to B = 1/√5, to C (a zero vector) = 0
        let q = tf_idf(&[2.0, 1.0, 5.0], &w);
        let s5 = 5f64.sqrt();
        assert!(close(cosine_similarity(&q, &v[0]), 2.0 / s5));
        assert!(close(cosine_similarity(&q, &v[1]), 1.0 / s5));
        assert_eq!(cosine_similarity(&q, &v[2]), 0.0);
        assert!(close(cosine_distance(&q, &v[0]), 1.0 - 2.0 / s5));
        assert!(close(cosine_similarity(&v[1], &v[1]), 1.0));
        // a word no shape uses
        assert_eq!(idf(&[vec![0.0, 1.0]]), [0.0, 0.0]);
    }

    #[test]
    fn bag_of_words_ranks_a_shape_with_its_own_kind() {
        let params = FpfhParams {
            points: 800,
            words: 32,
            ..FpfhParams::default()
        };
        let shapes = [
            synth::icosphere(3, 1.0),
            synth::icosphere(3, 2.0),
            synth::torus(1.0, 0.3, 48, 16),
            synth::torus(1.0, 0.35, 48, 16),
        ];
        let feats: Vec<Vec<Feature>> = shapes
            .iter()
            .map(|m| mesh_features(m, &params, FpfhScale::ScaleFree).unwrap())
            .collect();
        let (model, vectors) = BagOfWords::fit(&feats, &params, FpfhScale::ScaleFree).unwrap();
        assert_eq!(model.codebook.len(), 32);
        assert_eq!(vectors.len(), 4);
        // describing a collection mesh again gives its collection vector
        assert_eq!(model.describe(&shapes[2]).unwrap(), vectors[2]);
        let d = |i: usize, j: usize| cosine_distance(&vectors[i], &vectors[j]);
        assert!(d(0, 1) < d(0, 2) && d(0, 1) < d(0, 3));
        assert!(d(2, 3) < d(2, 0) && d(2, 3) < d(2, 1));
        // deterministic
        let (again, _) = BagOfWords::fit(&feats, &params, FpfhScale::ScaleFree).unwrap();
        assert_eq!(again.codebook, model.codebook);
    }

    #[test]
    fn rejects_degenerate_input() {
        let empty = Mesh {
            positions: vec![],
            faces: vec![],
        };
        let p = FpfhParams::default();
        assert_eq!(sample_oriented(&empty, &p), Err(FpfhError::ZeroArea));
        let m = synth::icosphere(1, 1.0);
        let bad = FpfhParams { words: 0, ..p };
        assert_eq!(sample_oriented(&m, &bad), Err(FpfhError::InvalidParams));
        let pts = sample_oriented(&m, &p).unwrap();
        assert!(matches!(
            fpfh(&pts, 0.0, 100),
            Err(FpfhError::InvalidRadius(_))
        ));
        assert_eq!(fpfh(&pts, 0.1, 1), Err(FpfhError::InvalidParams));
        assert_eq!(
            features_of(&pts, &p, FpfhScale::FileUnits { area: 0.0 })
                .map(|f| f.len())
                .map_err(|e| matches!(e, FpfhError::InvalidRadius(_))),
            Err(true)
        );
    }
}
