//! Parameters of the detector and their validation.

use serde::{Deserialize, Serialize};

/// Everything that can go wrong in this crate: parameters out of range, or a topology that was
/// not built from the mesh it is used with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum HarrisError {
    /// A parameter is out of its documented range.
    #[error("invalid Harris parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// The field, as written in [`HarrisParams`] (e.g. `selection.fraction`).
        name: &'static str,
        /// The offending value, formatted.
        value: String,
        /// What the value must be.
        reason: &'static str,
    },
    /// The [`keycomp_mesh::Topology`] has a different number of vertices than the mesh.
    #[error(
        "the topology has {topology} vertices but the mesh has {mesh}: build the Topology from the same mesh"
    )]
    TopologyMismatch {
        /// Vertices in the mesh.
        mesh: usize,
        /// Vertices in the topology.
        topology: usize,
    },
}

/// Which vertices around v take part in the quadratic fit (step 1 of the detector).
///
/// In both modes the neighbourhood is made of whole rings (ring r = vertices r edges away from v)
/// and keeps growing until it holds at least [`HarrisParams::min_points`] vertices (or the
/// connected piece runs out).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Neighborhood {
    /// Grow rings until the last ring's longest edge path from v exceeds
    /// `radius_fraction × diagonal` (see [`HarrisParams::length_reference`]), with at least [`HarrisParams::min_rings`]
    /// rings. The path length of a vertex in ring r is the length of the shortest edge path
    /// from v that steps outward one ring per edge. The paper's (and default) choice.
    Adaptive {
        /// Radius as a fraction of the mesh's diagonal (unitless). Default 0.01. Raising
        /// it fits larger patches (smoother responses, fewer and coarser keypoints, slower);
        /// lowering it below one edge length changes nothing (`min_rings` applies).
        radius_fraction: f64,
    },
    /// Exactly this many rings (≥ 1), more only if needed to reach `min_points`. Raising it
    /// smooths responses like a larger radius; ignores the mesh's resolution.
    Rings(usize),
}

/// The length that [`Neighborhood::Adaptive`] radii are fractions of.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum LengthReference {
    /// Diagonal of the axis-aligned bounding box of the vertices (the authors' choice, with the
    /// box computed from the vertices only). Changes when the mesh is rotated (up to a factor
    /// √3 for a cube), so rotated copies can get different neighbourhoods and keypoints.
    BoundingBoxDiagonal,
    /// `√(12 · E|p − μ|²)`, the root-mean-square distance of the surface from its centroid μ
    /// (area-weighted, exact over triangles) times √12 ([`crate::moment_diagonal`]). Rotation
    /// invariant, and equal to the bounding-box diagonal for a surface spread evenly over an
    /// axis-aligned box or a sphere, so the paper's fractions keep their meaning. Default.
    #[default]
    MomentDiagonal,
    /// The length unit: the square root of the area that counts as 1 ([`UnitArea`]; the mesh's
    /// own area unless the caller gives another). A fragment analysed in its source's unit
    /// then gets the radii its source gets, whatever share of it the fragment keeps. For
    /// reference, the moment diagonal of a unit-area sphere is 0.98 units.
    Unit,
}

/// The area that counts as 1 in the unit-area frame the responses are computed in, and that
/// [`Selection::PerArea`] budgets and [`LengthReference::Unit`] radii are measured in.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum UnitArea {
    /// The mesh's own surface area (the paper's normalisation, Section 4.1).
    #[default]
    Own,
    /// This area, in the mesh's units squared (> 0): for a fragment, the area of the shape it
    /// stands for, so that it is measured in its source's unit.
    Given(f64),
}

impl UnitArea {
    /// [`UnitArea::Own`] as the area of `mesh` itself ([`UnitArea::Given`]): taken before a
    /// smoothed copy is made, so that the copy (whose area smoothing shrinks a little) is
    /// measured in the input's unit.
    pub fn resolved(self, mesh: &keycomp_mesh::Mesh) -> UnitArea {
        UnitArea::Given(self.area(mesh))
    }

    /// The area that counts as 1 for `mesh`, in its units squared.
    pub fn area(self, mesh: &keycomp_mesh::Mesh) -> f64 {
        match self {
            UnitArea::Own => keycomp_mesh::geometry::total_area(mesh),
            UnitArea::Given(a) => a,
        }
    }
}

/// How keypoints are chosen among the candidates (vertices whose response is at least every
/// 1-ring neighbour's). All modes return keypoints best first (response descending, ties by
/// vertex id ascending).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Selection {
    /// The best `round(fraction × |V|)` candidates (at least 1, at most all candidates), where
    /// |V| counts vertices that faces refer to. Must be in (0, 1]. Default 0.01 (the paper's
    /// 1 %). Raising it gives more keypoints, including weaker ones.
    Fraction(f64),
    /// The best `n` candidates (fewer if there are fewer candidates). Must be ≥ 1.
    Count(usize),
    /// The best `round(density × area)` candidates (at least 1, at most all candidates), the
    /// area in the unit-area frame ([`UnitArea`]): a number per unit of area, so the same
    /// surface sampled at any density gets the same budget, and a fragment keeping the share f
    /// of its source (measured in the source's unit) gets f times the source's. Must be finite
    /// and > 0, at most [`Selection::MAX_DENSITY`]. Not in the paper, whose budget is a
    /// fraction of the vertices.
    PerArea(f64),
    /// Greedy spacing: candidates best first, skipping any closer (Euclidean) than
    /// `fraction_of_diagonal × moment diagonal` ([`crate::moment_diagonal`], a rotation
    /// invariant stand-in for the bounding-box diagonal) to an already chosen keypoint; stop
    /// after `max` keypoints if given. Raising the fraction spreads keypoints out and gives fewer.
    Spacing {
        /// Minimum distance between keypoints as a fraction of the moment diagonal (unitless,
        /// finite, ≥ 0).
        fraction_of_diagonal: f64,
        /// At most this many keypoints (≥ 1), or all that fit the spacing.
        max: Option<usize>,
    },
}

/// Parameters of the Harris 3D detector. `Default` is the paper's setting with this crate's
/// stable-fit rule: adaptive radius 0.01 × diagonal, at least 2 rings and 12 points, k = 0.04,
/// the best 1 % of vertices.
///
/// Deserialising fills missing fields from the default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HarrisParams {
    /// Neighbourhood of each vertex. Default `Adaptive { radius_fraction: 0.01 }`.
    pub neighborhood: Neighborhood,
    /// The length adaptive radii are fractions of. Default
    /// [`LengthReference::MomentDiagonal`] (rotation invariant); `BoundingBoxDiagonal` is the
    /// authors' choice.
    pub length_reference: LengthReference,
    /// Adaptive neighbourhoods only: the fewest whole rings used (≥ 1). Default 2. The authors'
    /// code uses 1, which on coarse meshes means about 7 points for 6 unknowns (an
    /// interpolation, not a fit). Raising it smooths; lowering it to 1 reproduces the authors'
    /// neighbourhoods on coarse meshes.
    pub min_rings: usize,
    /// The fewest vertices (v included) in a neighbourhood; rings are added until it is reached.
    /// A vertex whose connected piece has fewer vertices gets no response (NaN). Must be ≥ 6
    /// (the fit has 6 unknowns). Default 12: twice the unknowns, so every fit is redundant; a
    /// regular interior 2-ring (19 vertices) always satisfies it, so it only widens
    /// neighbourhoods at boundaries and low-valence vertices.
    pub min_points: usize,
    /// Harris constant k in `h = det − k·trace²` (unitless), in [0, 0.25). Default 0.04.
    /// Raising it penalises edge-like (one strong curvature direction) points more and lowers
    /// every response; at 0.25 no response can be positive.
    pub k: f64,
    /// Keypoint selection. Default `Fraction(0.01)`.
    pub selection: Selection,
    /// Taubin λ|μ pairs applied to a copy of the mesh before the responses are computed
    /// (`keycomp_mesh::smooth::taubin_with`, boundary vertices smoothed like the others), at
    /// most [`HarrisParams::MAX_SMOOTHING_ITERATIONS`]. Default 0: the responses of the mesh as
    /// it is, as in the paper. Raising it removes noise of a few edge lengths (Gaussian noise,
    /// isolated spikes) from the responses, and with it detail at that scale; each pair costs
    /// two passes over the vertices. Not in the paper: the robust preset of
    /// `keycomp_components` uses 30 (see its docs for the measurements).
    #[serde(default)]
    pub smoothing_iterations: usize,
    /// Smoothing given as a length instead of a number of passes: when set, the number of
    /// Taubin λ|μ pairs is `round((length / ē)⁴)` for ē the mean edge length in the unit-area
    /// frame ([`UnitArea`]; [`crate::smoothing_passes`]), at most
    /// [`HarrisParams::MAX_SMOOTHING_ITERATIONS`], and [`HarrisParams::smoothing_iterations`]
    /// is ignored, so that the same surface sampled at another density is smoothed alike.
    /// Default `None` (the count applies). Not in the paper.
    #[serde(default)]
    pub smoothing_length: Option<f64>,
    /// A vertex whose neighbourhood reaches the mesh's boundary gets no response (NaN), so it
    /// is never a keypoint: its quadratic is fitted to a one-sided neighbourhood, and along
    /// the ragged border of a scan or a fragment such fits give the largest responses of the
    /// mesh, at places that move with every cut. Default false, as in the paper; keycomp's
    /// analysis profile turns it on (not in the paper).
    #[serde(default)]
    pub skip_boundary: bool,
}

impl Default for HarrisParams {
    fn default() -> Self {
        HarrisParams {
            neighborhood: Neighborhood::Adaptive {
                radius_fraction: 0.01,
            },
            length_reference: LengthReference::MomentDiagonal,
            min_rings: 2,
            min_points: 12,
            k: 0.04,
            selection: Selection::Fraction(0.01),
            smoothing_iterations: 0,
            smoothing_length: None,
            skip_boundary: false,
        }
    }
}

impl HarrisParams {
    /// The largest accepted [`HarrisParams::smoothing_iterations`]: far beyond any useful
    /// value (a few tens), it bounds the time a configuration can ask for.
    pub const MAX_SMOOTHING_ITERATIONS: usize = 1000;
}

fn invalid(name: &'static str, value: impl std::fmt::Display, reason: &'static str) -> HarrisError {
    HarrisError::InvalidParameter {
        name,
        value: value.to_string(),
        reason,
    }
}

impl Selection {
    /// The largest accepted [`Selection::PerArea`] density (keypoints per unit area): far
    /// beyond any useful value (hundreds), it bounds what a recorded profile can ask for.
    pub const MAX_DENSITY: f64 = 1e6;

    /// Checks the ranges documented on each variant.
    pub fn validate(&self) -> Result<(), HarrisError> {
        match *self {
            Selection::Fraction(f) => {
                if !(f > 0.0 && f <= 1.0) {
                    return Err(invalid(
                        "selection.fraction",
                        f,
                        "must be in (0, 1], e.g. 0.01 for 1 % of the vertices",
                    ));
                }
            }
            Selection::Count(n) => {
                if n == 0 {
                    return Err(invalid("selection.count", n, "must be at least 1"));
                }
            }
            Selection::PerArea(d) => {
                if !(d.is_finite() && d > 0.0 && d <= Self::MAX_DENSITY) {
                    return Err(invalid(
                        "selection.per_area",
                        d,
                        "must be a number of keypoints per unit area in (0, 1e6], e.g. 400",
                    ));
                }
            }
            Selection::Spacing {
                fraction_of_diagonal,
                max,
            } => {
                if !(fraction_of_diagonal.is_finite() && fraction_of_diagonal >= 0.0) {
                    return Err(invalid(
                        "selection.fraction_of_diagonal",
                        fraction_of_diagonal,
                        "must be finite and ≥ 0, e.g. 0.05",
                    ));
                }
                if max == Some(0) {
                    return Err(invalid("selection.max", 0, "must be at least 1 (or None)"));
                }
            }
        }
        Ok(())
    }
}

impl HarrisParams {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), HarrisError> {
        match self.neighborhood {
            Neighborhood::Adaptive { radius_fraction } => {
                if !(radius_fraction.is_finite() && radius_fraction > 0.0) {
                    return Err(invalid(
                        "neighborhood.radius_fraction",
                        radius_fraction,
                        "must be finite and > 0, e.g. 0.01",
                    ));
                }
            }
            Neighborhood::Rings(k) => {
                if k == 0 {
                    return Err(invalid("neighborhood.rings", k, "must be at least 1"));
                }
            }
        }
        if self.smoothing_iterations > Self::MAX_SMOOTHING_ITERATIONS {
            return Err(invalid(
                "smoothing_iterations",
                self.smoothing_iterations,
                "must be at most 1000 (a few tens remove noise; 0 is the paper's method)",
            ));
        }
        if let Some(l) = self.smoothing_length
            && !(0.0..=1.0).contains(&l)
        {
            return Err(invalid(
                "smoothing_length",
                l,
                "must be a length in [0, 1] unit lengths, e.g. 0.026",
            ));
        }
        if self.min_rings == 0 {
            return Err(invalid("min_rings", self.min_rings, "must be at least 1"));
        }
        if self.min_points < 6 {
            return Err(invalid(
                "min_points",
                self.min_points,
                "must be at least 6 (the quadratic has 6 coefficients); 12 is recommended",
            ));
        }
        if !(self.k >= 0.0 && self.k < 0.25) {
            return Err(invalid("k", self.k, "must be in [0, 0.25), e.g. 0.04"));
        }
        self.selection.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_and_bad_values_are_rejected() {
        let d = HarrisParams::default();
        assert!(d.validate().is_ok());
        let bad = [
            HarrisParams {
                selection: Selection::Fraction(0.0),
                ..d
            },
            HarrisParams {
                selection: Selection::Fraction(1.5),
                ..d
            },
            HarrisParams {
                selection: Selection::Fraction(f64::NAN),
                ..d
            },
            HarrisParams {
                selection: Selection::Count(0),
                ..d
            },
            HarrisParams {
                selection: Selection::Spacing {
                    fraction_of_diagonal: f64::NAN,
                    max: None,
                },
                ..d
            },
            HarrisParams {
                neighborhood: Neighborhood::Rings(0),
                ..d
            },
            HarrisParams {
                smoothing_iterations: HarrisParams::MAX_SMOOTHING_ITERATIONS + 1,
                ..d
            },
            HarrisParams {
                neighborhood: Neighborhood::Adaptive {
                    radius_fraction: f64::NAN,
                },
                ..d
            },
            HarrisParams { k: f64::NAN, ..d },
            HarrisParams { k: -0.1, ..d },
            HarrisParams { min_points: 5, ..d },
            HarrisParams { min_rings: 0, ..d },
        ];
        for p in bad {
            let e = p.validate().expect_err("must be rejected");
            assert!(e.to_string().contains("invalid Harris parameter"), "{e}");
        }
    }

    #[test]
    fn serde_round_trip_and_defaults_for_missing_fields() {
        let p = HarrisParams {
            neighborhood: Neighborhood::Rings(3),
            selection: Selection::Spacing {
                fraction_of_diagonal: 0.05,
                max: Some(40),
            },
            ..HarrisParams::default()
        };
        let s = serde_json::to_string(&p).expect("serialise");
        let q: HarrisParams = serde_json::from_str(&s).expect("deserialise");
        assert_eq!(p, q);
        let partial: HarrisParams = serde_json::from_str(r#"{"k": 0.05}"#).expect("partial");
        assert_eq!(
            partial,
            HarrisParams {
                k: 0.05,
                ..HarrisParams::default()
            }
        );
    }
}
