//! Which detector: key-components or one of the paper's MSER comparisons.

/// A detection method: key-components or one of the MSER comparisons (Sipiran & Bustos 2013,
/// Sections 3 and 4.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Key-components (Harris 3D, geodesics, SMACOF, clustering, region growing).
    Kc,
    /// Every diffusion-geometric maximally stable component (the paper's Table 5).
    Mser,
    /// MSER key-components: the MSER components covering the HKS keypoints (Table 6).
    MserKc,
}

impl Method {
    /// `kc`, `mser` or `mser-kc`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Kc => "kc",
            Method::Mser => "mser",
            Method::MserKc => "mser-kc",
        }
    }

    /// The MSER output of an MSER method (`None` for key-components).
    pub fn mser_output(self) -> Option<crate::Output> {
        match self {
            Method::Kc => None,
            Method::Mser => Some(crate::Output::All),
            Method::MserKc => Some(crate::Output::KeyComponents),
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "kc" => Ok(Method::Kc),
            "mser" => Ok(Method::Mser),
            "mser-kc" | "mserkc" => Ok(Method::MserKc),
            _ => Err(format!("unknown method '{s}' (kc, mser or mser-kc)")),
        }
    }
}
