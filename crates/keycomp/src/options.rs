//! Detection options as a user gives them (a preset, then single values on top), turned into
//! [`DetectParams`]: the one place the command line and other front ends share.

use keycomp_components::{
    DetectParams, GeodesicOptions, Grouping, Preset, SaliencyParams, SmacofParams,
};
use keycomp_harris::{HarrisParams, Neighborhood, Selection};

/// N of Algorithm 1 scaled for small shapes in the retrieval commands (`index add`, `query`,
/// `match`) when not given and the keypoints are a fraction of the vertices (the paper's
/// presets): N = 30 for shapes of at least 250 keypoints (25k vertices), scaled down below.
/// A per-area keypoint budget (the robust preset) needs no scaling: every shape gets
/// keypoints in proportion to its area in its source's unit.
pub const RETRIEVAL_N_REFERENCE: usize = 250;

/// The preset of every command and binding when none is given: [`Preset::Robust`], whose
/// budgets and lengths are per unit of area and length.
pub const DEFAULT_PRESET: Preset = Preset::Robust;

/// Detection options: a preset of Section 4.3 of the paper or keycomp's robust preset, then
/// each option given on top. `None` keeps the preset's (or the default) value.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectOptions {
    /// The robust preset (the default: smoothed responses, keypoints per unit area, salient
    /// peaks as components), or KC-1 (R 0.15, T 0.30, N 30), KC-2 (N 20), KC-3 (R 0.10,
    /// T 0.20, N 30).
    pub preset: Preset,
    /// Keep this many keypoints per unit area (the robust preset's default 400).
    pub density: Option<f64>,
    /// Keep this fraction of the vertices as keypoints (the paper's presets' default 0.01).
    pub fraction: Option<f64>,
    /// Keep this many keypoints (instead of a fraction).
    pub count: Option<usize>,
    /// Harris neighbourhoods of this many rings (instead of the adaptive radius).
    pub rings: Option<usize>,
    /// Adaptive Harris neighbourhood radius, as a fraction of the reference length.
    pub radius: Option<f64>,
    /// Intra-cluster distance R.
    pub r: Option<f64>,
    /// Inter-cluster distance T.
    pub t: Option<f64>,
    /// Fewest keypoints in a cluster, N.
    pub n: Option<usize>,
    /// Scale N down below this many keypoints (0 = the paper's fixed N).
    pub n_reference: Option<usize>,
    /// Region-growing bound σ.
    pub sigma: Option<f64>,
    /// Seed of SMACOF's random starts.
    pub seed: Option<u64>,
    /// Fronts on a proxy of at most this many vertices (0 = the full mesh).
    pub geodesic_vertices: Option<usize>,
    /// Split obtuse corners of at least this angle, in degrees.
    pub split_angle: Option<f64>,
    /// Keypoints running a full front (0 = all of them).
    pub landmarks: Option<usize>,
    /// Where the other keypoints' fronts stop, in covering radii.
    pub landmark_radius: Option<f64>,
    /// Vertices per cell of the proxy's parallel simplification (0 = one cell).
    pub proxy_cell_vertices: Option<usize>,
    /// SMACOF's starts.
    pub smacof_starts: Option<usize>,
    /// Whether SMACOF's first start is the classical scaling.
    pub classical_start: Option<bool>,
    /// How keypoints become key-components: salient regions (true) or the paper's clustering
    /// (false); the preset's when unset.
    pub salient: Option<bool>,
    /// The saliency's diffusion time, in unit areas.
    pub saliency_time: Option<f64>,
    /// The share of its height a salient peak's saddle lies below it.
    pub prominence: Option<f64>,
    /// The geodesic radius of a salient component, in unit lengths.
    pub component_radius: Option<f64>,
    /// The most salient components.
    pub max_components: Option<usize>,
}

impl Default for DetectOptions {
    fn default() -> Self {
        DetectOptions {
            preset: DEFAULT_PRESET,
            density: None,
            fraction: None,
            count: None,
            rings: None,
            radius: None,
            r: None,
            t: None,
            n: None,
            n_reference: None,
            sigma: None,
            seed: None,
            geodesic_vertices: None,
            split_angle: None,
            landmarks: None,
            landmark_radius: None,
            proxy_cell_vertices: None,
            smacof_starts: None,
            classical_start: None,
            salient: None,
            saliency_time: None,
            prominence: None,
            component_radius: None,
            max_components: None,
        }
    }
}

impl DetectOptions {
    /// Whether the surface analysed, when none is asked for, is the canonical one: yes for the
    /// robust preset, no for the paper's presets, which select the surface the paper used (the
    /// mesh as read; a point cloud still gets its canonical surface): their budget of 1 % of
    /// the vertices measures the file's tessellation.
    pub fn canonical_by_default(&self) -> bool {
        !self.preset.is_paper()
    }

    /// The Harris parameters: `base` with the selection and neighbourhood options on top.
    pub fn harris(&self, mut base: HarrisParams) -> HarrisParams {
        if let Some(d) = self.density {
            base.selection = Selection::PerArea(d);
        }
        if let Some(f) = self.fraction {
            base.selection = Selection::Fraction(f);
        }
        if let Some(n) = self.count {
            base.selection = Selection::Count(n);
        }
        if let Some(k) = self.rings {
            base.neighborhood = Neighborhood::Rings(k);
        }
        if let Some(d) = self.radius {
            base.neighborhood = Neighborhood::Adaptive { radius_fraction: d };
        }
        base
    }

    /// The detection parameters (what `keycomp detect` uses): the preset (its Harris part
    /// included, [`Preset::harris_params`]), then each option.
    pub fn params(&self) -> DetectParams {
        let mut p = DetectParams {
            harris: self.harris(self.preset.harris_params()),
            components: self.preset.component_params(),
            geodesic: self.geodesic(),
        };
        p.components.smacof = self.smacof(p.components.smacof);
        let c = &mut p.components;
        if let Some(r) = self.r {
            c.cluster.r = r;
        }
        if let Some(t) = self.t {
            c.cluster.t = t;
        }
        if let Some(n) = self.n {
            c.cluster.n_min = n;
        }
        if let Some(k) = self.n_reference {
            c.cluster.n_reference = (k > 0).then_some(k);
        }
        if let Some(s) = self.sigma {
            c.sigma = s;
        }
        match self.salient {
            Some(true) if c.grouping == Grouping::Adaptive => {
                c.grouping = Grouping::Salient(SaliencyParams::default());
            }
            Some(false) => c.grouping = Grouping::Adaptive,
            _ => {}
        }
        if let Grouping::Salient(sp) = &mut c.grouping {
            if let Some(t) = self.saliency_time {
                sp.time = t;
            }
            if let Some(x) = self.prominence {
                sp.prominence = x;
            }
            if let Some(r) = self.component_radius {
                sp.radius = r;
            }
            if let Some(k) = self.max_components {
                sp.max_components = k;
            }
        }
        p
    }

    /// The geodesic options: the preset's ([`Preset::geodesic_options`]) with the proxy,
    /// corner and landmark options on top.
    pub fn geodesic(&self) -> GeodesicOptions {
        let mut g = self.preset.geodesic_options();
        if let Some(n) = self.geodesic_vertices {
            g.proxy_vertices = n;
        }
        if let Some(a) = self.split_angle {
            g.min_split_angle_degrees = a;
        }
        if let Some(l) = self.landmarks {
            g.landmarks = l;
        }
        if let Some(f) = self.landmark_radius {
            g.landmark_radius = f;
        }
        if let Some(c) = self.proxy_cell_vertices {
            g.proxy_cell_vertices = c;
        }
        g
    }

    /// SMACOF's parameters: `base` with the seed and start options on top.
    pub fn smacof(&self, mut base: SmacofParams) -> SmacofParams {
        if let Some(seed) = self.seed {
            base.seed = seed;
        }
        if let Some(n) = self.smacof_starts {
            base.starts = n;
        }
        if let Some(b) = self.classical_start {
            base.classical_start = b;
        }
        base
    }

    /// The parameters of the retrieval commands: [`DetectOptions::params`], with N scaled for
    /// small shapes when the keypoints are a fraction of the vertices, unless `n_reference`
    /// says otherwise ([`RETRIEVAL_N_REFERENCE`]).
    pub fn retrieval_params(&self) -> DetectParams {
        let mut p = self.params();
        if self.n_reference.is_none() && matches!(p.harris.selection, Selection::Fraction(_)) {
            p.components.cluster.n_reference = Some(RETRIEVAL_N_REFERENCE);
        }
        p
    }
}
