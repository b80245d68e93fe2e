//! The parameters of matching ([`MatchParams`]) and the defaults keycomp's commands derive
//! from a query: verification's weight for a query with a boundary ([`verify_weight_for`]) and
//! its search width on canonical surfaces ([`verify_search_for`]). Each field says its unit,
//! its default and what raising or lowering it does; the steps they steer are in the crate
//! documentation, *Steps*.

use serde::{Deserialize, Serialize};

use crate::verify;

/// Parameters of [`match_shapes`](crate::match_shapes).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MatchParams {
    /// Descriptor distance at which similarity reaches 0 (default 0.7). Lowering it makes
    /// matching stricter. On SHREC'07 Watertight and TOSCA fragments (scale-free), 0.7 raised
    /// mAP against 0.8 on every fragment kind but Watertight scans (Watertight balls 0.607 to
    /// 0.632, TOSCA balls 0.722 to 0.797; scans 0.431 to 0.427) for whole-shape mAP 0.006
    /// lower (BENCHMARKS.md, *Matching*).
    pub max_distance: f32,
    /// Largest factor by which two layout distances may disagree after scaling (default 1.5).
    /// Raising it tolerates more deformation and worse detections; 1 demands exact agreement.
    pub layout_tolerance: f64,
    /// Weighs each query part by its inverse frequency in the index when ranking
    /// ([`rank`](crate::rank)): parts with close counterparts in many shapes count less. Default
    /// false: on SHREC'07 Watertight it lowered fragment NN (balls 0.670 to 0.625, plane cuts 0.875
    /// to 0.825) for a whole-shape mAP gain of 0.012 (BENCHMARKS.md, *Ablation*).
    pub idf: bool,
    /// Largest factor by which a matched pair's part areas may disagree after scaling by the square
    /// of the layout's scale (step 4 of the crate documentation's *Steps*); 0 turns the check off.
    /// Default 6 (a factor of about 2.4 in length, between one and two patch levels): on SHREC'07
    /// Watertight and TOSCA fragments, tolerances 4, 6 and 9 all beat no check, 6 best overall
    /// (BENCHMARKS.md, *Size consistency*).
    pub area_tolerance: f64,
    /// Whether both shapes are measured in the same length unit
    /// ([`keycomp_describe::Units::File`]): the layout's scale is then 1 instead of an estimate,
    /// and the areas [`rank`](crate::rank) compares are each part's area fraction times its shape's
    /// surface area instead of the fraction alone (scale-free, where every shape has unit area).
    /// Default false.
    pub file_units: bool,
    /// How much the pose check weighs (step 5 of the crate documentation's *Steps*), in [0, 1]; 0
    /// turns it off. Default 0: classes of articulated shapes (an animal in several poses, a person
    /// in several poses) must be found whatever their pose, and at 0.5 FAUST's subjects, each in
    /// the same ten poses as the others, fall from mAP 0.607 to 0.349 (a shape in the query's pose
    /// ranks above the query's subject in another pose). Where the pose is part of what is sought
    /// (a fragment's exact source, rigid objects), 0.5 raised every SHREC'07 Watertight row in both
    /// length modes (balls 0.890 / 0.632 to 0.925 / 0.642 NN / mAP, source first 153 to 164 of 200)
    /// and, in file units, put TOSCA fragments' exact source first for 63 instead of 50 of 108
    /// (BENCHMARKS.md, *The pose check*).
    pub pose_weight: f64,
    /// Largest factor by which two straight-line distances between matched centres may
    /// disagree after scaling for the pose check to count the pair as agreeing (default
    /// 1.25). Raising it tolerates more bending; 1 demands agreement within
    /// [`POSE_SLACK`](crate::POSE_SLACK).
    pub pose_tolerance: f64,
    /// How much geometric verification weighs (step 6 of the crate documentation's *Steps*,
    /// [`verify`]), in [0, 1]; 0 turns it off. Each candidate's score is multiplied by
    /// `1 − γ·(1 − f)`, f the share of the query's surface sample that lies on the target's once
    /// aligned. Default 0 here; keycomp's `query`, `match` and `bench retrieval` use
    /// [`verify_weight_for`]: 0.5 (1 in file units) for a query with a boundary (a fragment, a
    /// scan), 0 for a closed shape.
    pub verify_weight: f64,
    /// Distance (in the target's length unit: unit area when scale-free) within which a
    /// query sample point counts as lying on the target's surface (default 0.03, about 1.4
    /// times the mean distance from a point of a unit-area surface to the nearest of 512
    /// points drawn on it). On TOSCA and SHREC'07 Watertight fragments 0.03 beat 0.04 on
    /// most rows, scale-free scans most (TOSCA NN 0.667 to 0.778: BENCHMARKS.md, *Geometric
    /// verification*). Raising it counts points farther off the surface as on it.
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

/// A weight clamped to [0, 1]; 0 when it is not a number.
pub(crate) fn unit_weight(w: f64) -> f64 {
    if w.is_finite() {
        w.clamp(0.0, 1.0)
    } else {
        0.0
    }
}
