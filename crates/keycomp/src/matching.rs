//! Matching two meshes part to part (`keycomp match`): both are analysed under one profile and
//! their parts paired by Kuhn–Munkres on descriptor distances, then checked for a consistent
//! layout (`keycomp_retrieval::match_shapes`).

use std::path::Path;
use std::time::Instant;

use keycomp_components::DetectParams;
use keycomp_mesh::read_mesh;
pub use keycomp_retrieval::MatchParams;
use keycomp_surface::SurfaceParams;
use serde::{Deserialize, Serialize};

use crate::collection::Units;
use crate::options::DetectOptions;
use crate::{Analysed, Error, Profile, Role, analyse, analyse_as};

/// A part of A paired with a part of B.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PairMatch {
    /// A's part (index into its description's parts).
    pub a_component: usize,
    /// B's part.
    pub b_component: usize,
    /// Descriptor distance of the pair.
    pub distance: f32,
}

/// Where a match's time went, in milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MatchTimings {
    /// Analysing A (reading included for a file).
    pub a: f64,
    /// Analysing B.
    pub b: f64,
    /// Matching.
    pub matching: f64,
}

/// The match of A (the query side: the score is relative to its parts) against B, as
/// `keycomp match --json` prints it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MatchResult {
    /// A's name.
    pub a: String,
    /// B's name.
    pub b: String,
    /// Parts of A (of its description under `hypothesis`).
    pub components_a: usize,
    /// A's scale hypothesis that gave the match (`Analysed::hypothesis`): 0 unless A is a
    /// scale-free query with a boundary, described under several.
    pub hypothesis: usize,
    /// Parts of B.
    pub components_b: usize,
    /// Score in [0, 1].
    pub score: f64,
    /// Estimated B/A length ratio, when three or more matches allowed an estimate.
    pub scale: Option<f64>,
    /// Pairs dropped by the layout and size checks.
    pub rejected: usize,
    /// The pose check's agreement: of the pairs of kept matches it compared, the fraction
    /// whose straight-line distances agree (`None` when it compared none).
    pub pose: Option<f64>,
    /// Geometric verification's fitness: the share of A's surface sample on B's surface once
    /// aligned (`None` when it did not run: off, or fewer than three pairs to align with).
    pub verified: Option<f64>,
    /// Where A sits on B: the similarity transform from A's file coordinates to B's
    /// ([`crate::transform`]); `None` when no alignment was found.
    pub transform: Option<crate::transform::Transform>,
    /// The kept pairs, ordered by A's part.
    pub matches: Vec<PairMatch>,
    /// Where the time went.
    pub timings_ms: MatchTimings,
}

/// How [`match_files`] analyses the two meshes.
#[derive(Debug, Clone)]
pub struct MatchOptions {
    /// Detection parameters; `None`: the retrieval default.
    pub detect: Option<DetectParams>,
    /// Length unit; a file unit not given is the square root of B's area.
    pub units: Units,
    /// Both sides analysed on their canonical surface ([`Profile::with_surface`]; the
    /// default), or as read (`false`).
    pub canonical: bool,
    /// Weight of the pose check (`keycomp_retrieval::MatchParams::pose_weight`, in [0, 1];
    /// default 0: no pose check).
    pub pose_weight: f64,
    /// Weight of geometric verification (`keycomp_retrieval::MatchParams::verify_weight`, in
    /// [0, 1]); `None` (the default): automatic, by whether A has a boundary
    /// (`keycomp_retrieval::verify_weight_for`).
    pub verify_weight: Option<f64>,
}

impl Default for MatchOptions {
    fn default() -> Self {
        MatchOptions {
            detect: None,
            units: Units::default(),
            canonical: true,
            pose_weight: 0.0,
            verify_weight: None,
        }
    }
}

pub use keycomp_retrieval::verify_weight_for;

/// Checks a pose weight ([`MatchParams::pose_weight`]): a number in [0, 1].
pub fn check_pose_weight(weight: f64) -> Result<f64, Error> {
    check_weight("pose", weight)
}

/// Checks a verification weight ([`MatchParams::verify_weight`]): `None` (automatic, see
/// `keycomp_retrieval::verify_weight_for`) or a number in [0, 1].
pub fn check_verify_weight(weight: Option<f64>) -> Result<Option<f64>, Error> {
    weight.map(|w| check_weight("verification", w)).transpose()
}

fn check_weight(what: &str, weight: f64) -> Result<f64, Error> {
    if (0.0..=1.0).contains(&weight) {
        Ok(weight)
    } else {
        Err(Error::Invalid(format!(
            "the {what} weight must be between 0 and 1, got {weight}"
        )))
    }
}

/// Matches two analysed meshes, named `a` and `b` in the result, with `params`
/// (`file_units` is set from the analyses).
pub fn match_analysed(
    a: &Analysed,
    b: &Analysed,
    names: (&str, &str),
    params: &MatchParams,
) -> MatchResult {
    let t = Instant::now();
    let (m, hypothesis) = a.match_with(b, params);
    let (descriptors, centres) = b.full_view_of(0);
    let target = keycomp_retrieval::ShapeView {
        descriptors: &descriptors,
        layout: &b.description.layout,
        areas: &[],
        centres: &centres,
        sample: &b.description.sample,
    };
    let transform = crate::transform::Transform::refined_best(
        &a.transforms_onto(hypothesis, &m, target, b.frame_factor(0), params),
        a.input.positions(),
        b.surface_mesh(),
        b.file_units(),
    );
    let matching = t.elapsed().as_secs_f64() * 1e3;
    MatchResult {
        a: names.0.to_string(),
        b: names.1.to_string(),
        components_a: a.hypothesis(hypothesis).components.len(),
        hypothesis,
        components_b: b.description.components.len(),
        score: m.score,
        scale: m.scale,
        rejected: m.rejected,
        pose: m.pose,
        verified: m.verified,
        transform,
        matches: m
            .matches
            .iter()
            .map(|x| PairMatch {
                a_component: x.query,
                b_component: x.target,
                distance: x.distance,
            })
            .collect(),
        timings_ms: MatchTimings {
            a: a.ms,
            b: b.ms,
            matching,
        },
    }
}

/// The profile both sides of a match are analysed under.
pub fn match_profile(options: &MatchOptions, b: &Path) -> Result<Profile, Error> {
    let describe = options.units.describe_params(|| {
        read_mesh(b)
            .map(|m| vec![keycomp_mesh::geometry::total_area(&m.mesh)])
            .unwrap_or_default()
    })?;
    let detect = options
        .detect
        .clone()
        .unwrap_or_else(|| DetectOptions::default().retrieval_params());
    Ok(Profile::with(&detect, describe)
        .with_surface(options.canonical.then(SurfaceParams::default)))
}

/// Reads, analyses (in parallel) and matches the mesh files `a` and `b`; returns both
/// analyses (A's description the one of the hypothesis that gave the match) and the match.
pub fn match_files(
    a: &Path,
    b: &Path,
    options: &MatchOptions,
) -> Result<(Analysed, Analysed, MatchResult), Error> {
    let pose_weight = check_pose_weight(options.pose_weight)?;
    let verify_weight = check_verify_weight(options.verify_weight)?;
    let profile = match_profile(options, b)?;
    let (x, y) = rayon::join(
        || analyse_as(a, &profile, Role::Query),
        || analyse(b, &profile),
    );
    let (mut x, y) = (x?, y?);
    let params = MatchParams {
        pose_weight,
        verify_weight: x.verify_weight(verify_weight),
        ..MatchParams::default()
    };
    let m = match_analysed(
        &x,
        &y,
        (&a.display().to_string(), &b.display().to_string()),
        &params,
    );
    x.select(m.hypothesis);
    Ok((x, y, m))
}
