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

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::{ClusterParams, ComponentsError, SmacofParams};

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
}

impl Preset {
    /// All presets, in order.
    pub const ALL: [Preset; 3] = [Preset::Kc1, Preset::Kc2, Preset::Kc3];

    /// The clustering parameters of this preset (`iterations` = 10).
    pub fn cluster_params(self) -> ClusterParams {
        let (r, t, n_min) = match self {
            Preset::Kc1 => (0.15, 0.30, 30),
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

    /// The full parameters of this preset: its clustering, σ = 1.5, default SMACOF.
    pub fn component_params(self) -> ComponentParams {
        ComponentParams {
            cluster: self.cluster_params(),
            sigma: 1.5,
            smacof: SmacofParams::default(),
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Preset::Kc1 => "KC-1",
            Preset::Kc2 => "KC-2",
            Preset::Kc3 => "KC-3",
        })
    }
}

impl FromStr for Preset {
    type Err = ComponentsError;

    /// Accepts `KC-1`, `kc1`, `kc-1` (any case), and likewise for 2 and 3.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().replace('-', "").as_str() {
            "kc1" => Ok(Preset::Kc1),
            "kc2" => Ok(Preset::Kc2),
            "kc3" => Ok(Preset::Kc3),
            _ => Err(ComponentsError::param(
                "preset",
                s,
                "unknown preset; use KC-1, KC-2 or KC-3",
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
