//! Parameters of the components stage as a whole, and the paper's presets (Section 4.3).
//!
//! | preset | R | T | N |
//! |---|---|---|---|
//! | KC-1 (default) | 0.15 | 0.30 | 30 |
//! | KC-2 | 0.15 | 0.30 | 20 |
//! | KC-3 | 0.10 | 0.20 | 30 |
//!
//! R and T are geodesic distances on the mesh normalised to surface area 1. All three presets
//! use 1 % of the vertices as keypoints (a Harris parameter, not part of this crate), σ = 1.5
//! and `Iter` = 10.
//!
//! # The robust preset (not in the paper)
//!
//! [`Preset::Robust`], the default analysis's preset, keeps the paper's idea (key-components
//! are where Harris 3D responds most, grown on the surface) and changes every step that
//! depends on the triangles rather than on the surface ([`Preset::harris_params`],
//! [`Preset::component_params`]):
//! 1. Harris 3D in lengths: neighbourhoods of [`Preset::ROBUST_HARRIS_RADIUS`] unit lengths,
//!    on a copy smoothed over [`Preset::ROBUST_SMOOTHING_LENGTH`] unit lengths, keypoints at
//!    [`Preset::ROBUST_KEYPOINT_DENSITY`] per unit area rather than a share of the vertices;
//! 2. components as the prominent peaks of the diffused response, each a geodesic disc
//!    ([`Grouping::Salient`], [`crate::saliency`]) instead of SMACOF and Algorithm 1, whose
//!    order-dependent assignment a few moved keypoints reorder.
//!
//! With `keycomp bench repeatability` on canonical surfaces (BENCHMARKS.md, *Repeatability*),
//! every row of the paper's transformations and the re-tessellation rows stay at 0.86 or
//! more, where the paper's KC-1 averages 0.79 on meshes that share their triangles.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use keycomp_harris::{HarrisParams, LengthReference, Neighborhood, Selection};

use crate::cluster::ClusterParams;
use crate::error::ComponentsError;
use crate::saliency::SaliencyParams;
use crate::smacof::SmacofParams;
use crate::sphere::SphereRule;

/// Everything this crate needs to turn keypoints and their geodesic distances into
/// key-components. The default is the paper's KC-1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ComponentParams {
    /// Adaptive clustering of the keypoints' 2-D images (Algorithm 1); R, T, N, Iter.
    pub cluster: ClusterParams,
    /// Scale σ of the enclosing sphere's radius that bounds region growing (unitless; default
    /// 1.5, the paper's value; the paper recommends (1, 2]). Any value > 0 is accepted: below 1
    /// keypoints on the sphere can never be reached; raising it gives larger, more surely
    /// connected components that may spread beyond the keypoints' region.
    pub sigma: f64,
    /// Multidimensional scaling of the geodesic distance matrix to the plane (SMACOF).
    pub smacof: SmacofParams,
    /// The sphere whose σ-scaled radius bounds region growing. Default
    /// [`SphereRule::Enclosing`], the paper's.
    #[serde(default)]
    pub sphere: SphereRule,
    /// How keypoints become key-components: the paper's SMACOF embedding, Algorithm 1 and
    /// sphere-bounded growing ([`Grouping::Adaptive`], the default and what a recorded
    /// parameter set without the field reads as), or the robust preset's salient regions
    /// ([`Grouping::Salient`]: no geodesic matrix, no SMACOF; `cluster`, `sigma`, `smacof`
    /// and `sphere` are then unused).
    #[serde(default)]
    pub grouping: Grouping,
}

/// How keypoints become key-components ([`ComponentParams::grouping`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub enum Grouping {
    /// The paper's Sections 3.2–3.3: geodesic distances between the keypoints, SMACOF to the
    /// plane, adaptive clustering (Algorithm 1), geodesic centre and region growing in a
    /// sphere (Algorithm 2).
    #[default]
    Adaptive,
    /// Prominent peaks of the diffused Harris response with geodesic discs around them
    /// ([`crate::saliency`]; not in the paper).
    Salient(SaliencyParams),
}

impl Default for ComponentParams {
    fn default() -> Self {
        Preset::Kc1.component_params()
    }
}

impl ComponentParams {
    /// Checks every field (see [`ClusterParams::validate`], [`SmacofParams::validate`]) and
    /// that `sigma` is a finite number > 0.
    pub fn validate(&self) -> Result<(), ComponentsError> {
        self.cluster.validate()?;
        self.smacof.validate()?;
        self.sphere.validate()?;
        if let Grouping::Salient(p) = &self.grouping {
            p.validate()?;
        }
        if !(self.sigma.is_finite() && self.sigma > 0.0) {
            return Err(ComponentsError::param(
                "sigma",
                self.sigma,
                "must be a finite number > 0 (the paper uses 1.5, from (1, 2])",
            ));
        }
        Ok(())
    }
}

/// The paper's three best configurations (Section 4.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Preset {
    /// KC-1: R = 0.15, T = 0.30, N = 30 (large regions; the default).
    #[default]
    #[serde(rename = "KC-1", alias = "kc1", alias = "kc-1")]
    Kc1,
    /// KC-2: R = 0.15, T = 0.30, N = 20.
    #[serde(rename = "KC-2", alias = "kc2", alias = "kc-2")]
    Kc2,
    /// KC-3: R = 0.10, T = 0.20, N = 30 (medium regions).
    #[serde(rename = "KC-3", alias = "kc3", alias = "kc-3")]
    Kc3,
    /// keycomp's robust preset (not in the paper): smoothed Harris responses in neighbourhoods
    /// of fixed length, keypoints per unit area, and components as the salient peaks of the
    /// diffused response ([`Grouping::Salient`]; see *The robust preset* in the module docs).
    #[serde(rename = "robust", alias = "Robust", alias = "ROBUST")]
    Robust,
}

impl Preset {
    /// The paper's presets, in order.
    pub const ALL: [Preset; 3] = [Preset::Kc1, Preset::Kc2, Preset::Kc3];

    /// How far Harris 3D's copy is smoothed in the robust preset, in unit lengths
    /// (`HarrisParams::smoothing_length`): 30 Taubin λ|μ pairs on a default canonical surface
    /// (mean edge 0.011 unit lengths), (0.0257/ē)⁴ on a mesh of mean edge ē.
    pub const ROBUST_SMOOTHING_LENGTH: f64 = 0.0257;
    /// Keypoints per unit area in the robust preset (`Selection::PerArea`): about 4 % of a
    /// default canonical surface's vertices, 2 % of a 20,000-vertex mesh's.
    pub const ROBUST_KEYPOINT_DENSITY: f64 = 400.0;
    /// Harris neighbourhoods of the robust preset reach this many unit lengths
    /// (`LengthReference::Unit`): two rings of a default canonical surface.
    pub const ROBUST_HARRIS_RADIUS: f64 = 0.02;
    /// [`SphereRule::Spread`]'s factor in the robust preset.
    pub const ROBUST_SPREAD_FACTOR: f64 = 1.2;
    /// SMACOF's over-relaxation in the robust preset ([`SmacofParams::relaxation`]).
    pub const ROBUST_SMACOF_RELAXATION: f64 = 1.5;

    /// Whether this is one of the paper's presets (KC-1, KC-2, KC-3).
    pub fn is_paper(self) -> bool {
        !matches!(self, Preset::Robust)
    }

    /// The Harris 3D parameters of this preset: the paper's (`HarrisParams::default()`) for
    /// KC-1..3; smoothed responses, neighbourhoods in lengths and keypoints per unit area for
    /// the robust preset.
    pub fn harris_params(self) -> HarrisParams {
        match self {
            Preset::Robust => HarrisParams {
                smoothing_length: Some(Self::ROBUST_SMOOTHING_LENGTH),
                selection: Selection::PerArea(Self::ROBUST_KEYPOINT_DENSITY),
                neighborhood: Neighborhood::Adaptive {
                    radius_fraction: Self::ROBUST_HARRIS_RADIUS,
                },
                length_reference: LengthReference::Unit,
                ..HarrisParams::default()
            },
            _ => HarrisParams::default(),
        }
    }

    /// The clustering parameters of this preset (`iterations` = 10).
    pub fn cluster_params(self) -> ClusterParams {
        let (r, t, n_min) = match self {
            Preset::Kc1 | Preset::Robust => (0.15, 0.30, 30),
            Preset::Kc2 => (0.15, 0.30, 20),
            Preset::Kc3 => (0.10, 0.20, 30),
        };
        ClusterParams {
            r,
            t,
            n_min,
            iterations: 10,
            n_reference: None,
        }
    }

    /// The full parameters of this preset: the paper's clustering, σ = 1.5, SMACOF and
    /// enclosing sphere for KC-1..3; salient regions ([`Grouping::Salient`]) for the robust
    /// preset (its clustering, SMACOF and sphere fields are kept for `--grouping adaptive`).
    pub fn component_params(self) -> ComponentParams {
        ComponentParams {
            cluster: self.cluster_params(),
            sigma: 1.5,
            smacof: match self {
                Preset::Robust => SmacofParams {
                    starts: 1,
                    relaxation: Self::ROBUST_SMACOF_RELAXATION,
                    ..SmacofParams::default()
                },
                _ => SmacofParams::default(),
            },
            sphere: match self {
                Preset::Robust => SphereRule::Spread {
                    factor: Self::ROBUST_SPREAD_FACTOR,
                },
                _ => SphereRule::Enclosing,
            },
            grouping: match self {
                Preset::Robust => Grouping::Salient(SaliencyParams::default()),
                _ => Grouping::Adaptive,
            },
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Preset::Kc1 => "KC-1",
            Preset::Kc2 => "KC-2",
            Preset::Kc3 => "KC-3",
            Preset::Robust => "robust",
        })
    }
}

impl FromStr for Preset {
    type Err = ComponentsError;

    /// Accepts `KC-1`, `kc1`, `kc-1` (any case), likewise for 2 and 3, and `robust`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().replace('-', "").as_str() {
            "kc1" => Ok(Preset::Kc1),
            "kc2" => Ok(Preset::Kc2),
            "kc3" => Ok(Preset::Kc3),
            "robust" => Ok(Preset::Robust),
            _ => Err(ComponentsError::param(
                "preset",
                s,
                "unknown preset; use KC-1, KC-2, KC-3 or robust",
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_match_the_paper() {
        let p = |r, t, n| ClusterParams {
            r,
            t,
            n_min: n,
            iterations: 10,
            n_reference: None,
        };
        assert_eq!(Preset::Kc1.cluster_params(), p(0.15, 0.30, 30));
        assert_eq!(Preset::Kc2.cluster_params(), p(0.15, 0.30, 20));
        assert_eq!(Preset::Kc3.cluster_params(), p(0.10, 0.20, 30));
        assert_eq!(ComponentParams::default().cluster, ClusterParams::default());
        assert_eq!(ComponentParams::default().sigma, 1.5);
        for preset in Preset::ALL {
            preset.component_params().validate().unwrap();
            assert_eq!(preset.to_string().parse::<Preset>().unwrap(), preset);
        }
        assert_eq!("kc3".parse::<Preset>().unwrap(), Preset::Kc3);
        assert!("kc4".parse::<Preset>().is_err());
    }

    #[test]
    fn the_robust_preset_is_kc1_clustering_with_its_three_changes() {
        let r = Preset::Robust;
        assert!(!r.is_paper() && Preset::ALL.iter().all(|p| p.is_paper()));
        assert!(!Preset::ALL.contains(&r));
        assert_eq!(r.cluster_params(), Preset::Kc1.cluster_params());
        let c = r.component_params();
        c.validate().unwrap();
        assert_eq!(c.sigma, 1.5);
        assert_eq!(c.sphere, SphereRule::Spread { factor: 1.2 });
        assert_eq!(c.smacof.starts, 1);
        let h = r.harris_params();
        h.validate().unwrap();
        assert_eq!(h.smoothing_length, Some(0.0257));
        assert_eq!(h.selection, Selection::PerArea(400.0));
        assert_eq!(h.length_reference, LengthReference::Unit);
        assert_eq!(
            HarrisParams {
                smoothing_length: None,
                selection: Selection::Fraction(0.01),
                neighborhood: Neighborhood::Adaptive {
                    radius_fraction: 0.01
                },
                length_reference: LengthReference::MomentDiagonal,
                ..h
            },
            HarrisParams::default()
        );
        // the paper's presets keep the paper's Harris 3D and sphere
        for p in Preset::ALL {
            assert_eq!(p.harris_params(), HarrisParams::default());
            assert_eq!(p.component_params().sphere, SphereRule::Enclosing);
            assert_eq!(p.component_params().smacof, SmacofParams::default());
        }
        assert_eq!(r.to_string(), "robust");
        assert_eq!("Robust".parse::<Preset>().unwrap(), r);
        assert_eq!(serde_json::to_string(&r).unwrap(), r#""robust""#);
        // a recorded parameter set without a sphere rule is the paper's
        let old: ComponentParams = serde_json::from_str(r#"{"sigma": 1.5}"#).unwrap();
        assert_eq!(old.sphere, SphereRule::Enclosing);
    }

    #[test]
    fn serde_round_trip_and_partial_configs() {
        let p = Preset::Kc3.component_params();
        let json = serde_json::to_string(&p).unwrap();
        assert_eq!(serde_json::from_str::<ComponentParams>(&json).unwrap(), p);
        // missing fields take their defaults
        let partial: ComponentParams =
            serde_json::from_str(r#"{"cluster": {"n_min": 20}, "sigma": 1.2}"#).unwrap();
        assert_eq!(partial.cluster, Preset::Kc2.cluster_params());
        assert_eq!(partial.sigma, 1.2);
        assert_eq!(partial.smacof, SmacofParams::default());
        assert_eq!(serde_json::to_string(&Preset::Kc2).unwrap(), r#""KC-2""#);
        assert_eq!(
            serde_json::from_str::<Preset>(r#""kc1""#).unwrap(),
            Preset::Kc1
        );
    }

    #[test]
    fn validation_rejects_nonsense() {
        let ok = ComponentParams::default();
        let bad = |f: &dyn Fn(&mut ComponentParams)| {
            let mut p = ok.clone();
            f(&mut p);
            p.validate().is_err()
        };
        assert!(bad(&|p| p.sigma = 0.0));
        assert!(bad(&|p| p.sigma = -1.0));
        assert!(bad(&|p| p.sigma = f64::INFINITY));
        assert!(bad(&|p| p.sphere = SphereRule::Spread { factor: -1.0 }));
        assert!(bad(&|p| p.cluster.r = 0.5));
        assert!(bad(&|p| p.cluster.r = -0.1));
        assert!(bad(&|p| p.cluster.t = f64::NAN));
        assert!(bad(&|p| p.cluster.iterations = 0));
        assert!(bad(&|p| p.smacof.starts = 0));
        assert!(bad(&|p| p.smacof.max_iter = 0));
        assert!(bad(&|p| p.smacof.rel_tol = -1.0));
        assert!(!bad(&|p| p.sigma = 0.9));
        let msg = {
            let mut p = ok.clone();
            p.cluster.r = 0.5;
            p.validate().unwrap_err().to_string()
        };
        assert!(msg.contains("cluster.r"), "{msg}");
    }
}
