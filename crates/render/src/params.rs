//! Render parameters: image size, view, lighting, shading, anti-aliasing and outlines.

use crate::error::RenderError;

/// Which world axis points up in the picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpAxis {
    /// +Y is up and the front view looks from +Z towards −Z (OBJ/OFF convention of most scans
    /// and of the synthetic shapes).
    #[default]
    Y,
    /// +Z is up and the front view looks from −Y towards +Y (CAD and some scan conventions).
    Z,
}

/// How normals are chosen for lighting.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shading {
    /// One normal per face: facets are visible, creases stay sharp.
    Flat,
    /// Area-weighted vertex normals interpolated across each face and renormalised per sample
    /// (Phong interpolation of normals, Lambert lighting): smooth surfaces look smooth. Needs a
    /// consistently oriented mesh; where orientation flips, facets show.
    #[default]
    Smooth,
}

/// Thin dark lines along silhouettes, depth discontinuities and sharp creases, found in image
/// space from the visibility buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outline {
    /// Line colour (sRGB). Default `[30, 30, 30]`.
    pub color: [u8; 3],
    /// Line width in output pixels. Default 1.0; raising it thickens the lines (drawn with
    /// sub-pixel precision when supersampling is on).
    pub width: f64,
    /// Two neighbouring faces whose normals differ by more than this many degrees draw a crease
    /// line between them. Default 60°; lower it to show more feature edges, set it to 180° or
    /// more to draw silhouettes only.
    pub crease_angle_deg: f64,
    /// A depth jump larger than this fraction of the bounding-sphere diameter, between
    /// neighbouring samples and beyond what the nearer face's plane explains, is a silhouette.
    /// Default 0.01; lower it to outline shallower overlaps, raise it to ignore them.
    pub depth_gap: f64,
}

impl Default for Outline {
    fn default() -> Self {
        Outline {
            color: [30, 30, 30],
            width: 1.0,
            crease_angle_deg: 60.0,
            depth_gap: 0.01,
        }
    }
}

/// Parameters of [`render`](crate::render).
///
/// The camera is orthographic and fitted to the bounding sphere of the mesh (centred on the
/// bounding box of the vertices faces use, radius the largest distance from that centre to
/// such a vertex), so every view shows the whole shape, centred, at the same scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderParams {
    /// Width and height of the square image in pixels. Default 512; 1 to 8192.
    pub size: u32,
    /// Camera azimuth in degrees: rotation about the up axis, from the front view (see
    /// [`UpAxis`]) towards +X; 180 looks at the back. Default 30.
    pub azimuth_deg: f64,
    /// Camera elevation in degrees above the horizontal plane; 90 looks straight down, −90
    /// straight up. Default 20.
    pub elevation_deg: f64,
    /// Which world axis is up. Default [`UpAxis::Y`].
    pub up: UpAxis,
    /// Background colour as sRGB plus alpha; alpha 0 gives a transparent background (the PNG is
    /// then RGBA with anti-aliased edges in the alpha channel). Default opaque white.
    pub background: [u8; 4],
    /// Fraction of the image width left empty on each side of the bounding sphere. Default
    /// 0.04; must be in [0, 0.45].
    pub margin: f64,
    /// Flat or smooth shading. Default [`Shading::Smooth`].
    pub shading: Shading,
    /// Light every surface receives regardless of orientation, as a fraction of its colour.
    /// Default 0.25; raising it flattens the shading.
    pub ambient: f64,
    /// Lambert weight of a light at the camera (two-sided: back faces are lit as if turned to
    /// the viewer). Default 0.55.
    pub headlight: f64,
    /// Lambert weight of a key light from the upper left, in front of the shape (fixed relative
    /// to the camera, so it moves with the view). Default 0.35; raising it deepens the shadows
    /// on the lower right.
    pub key_light: f64,
    /// Supersampling factor per axis: `n` renders `n × n` samples per pixel and averages them
    /// (anti-aliasing). Default 2; 1 turns anti-aliasing off; 1 to 4. Time grows as `n²`.
    pub supersampling: u32,
    /// Outline of silhouettes and creases, or `None` for no lines. Default
    /// `Some(Outline::default())`.
    pub outline: Option<Outline>,
}

impl Default for RenderParams {
    fn default() -> Self {
        RenderParams {
            size: 512,
            azimuth_deg: 30.0,
            elevation_deg: 20.0,
            up: UpAxis::Y,
            background: [255, 255, 255, 255],
            margin: 0.04,
            shading: Shading::Smooth,
            ambient: 0.25,
            headlight: 0.55,
            key_light: 0.35,
            supersampling: 2,
            outline: Some(Outline::default()),
        }
    }
}

/// Largest image side accepted by [`RenderParams::validate`].
pub const MAX_SIZE: u32 = 8192;

/// Largest supersampling factor accepted by [`RenderParams::validate`].
pub const MAX_SUPERSAMPLING: u32 = 4;

impl RenderParams {
    /// Checks every field's range; the error names the field and the accepted range.
    pub fn validate(&self) -> Result<(), RenderError> {
        fn bad(name: &'static str, value: impl ToString, expected: &'static str) -> RenderError {
            RenderError::InvalidParam {
                name,
                value: value.to_string(),
                expected,
            }
        }
        if !(1..=MAX_SIZE).contains(&self.size) {
            return Err(bad("size", self.size, "a pixel count from 1 to 8192"));
        }
        if !(1..=MAX_SUPERSAMPLING).contains(&self.supersampling) {
            return Err(bad("supersampling", self.supersampling, "1, 2, 3 or 4"));
        }
        if !self.azimuth_deg.is_finite() {
            return Err(bad(
                "azimuth",
                self.azimuth_deg,
                "a finite angle in degrees",
            ));
        }
        if !(-90.0..=90.0).contains(&self.elevation_deg) {
            return Err(bad(
                "elevation",
                self.elevation_deg,
                "an angle from -90 to 90 degrees",
            ));
        }
        if !(0.0..=0.45).contains(&self.margin) {
            return Err(bad("margin", self.margin, "a fraction from 0 to 0.45"));
        }
        for (name, v) in [
            ("ambient", self.ambient),
            ("headlight", self.headlight),
            ("key_light", self.key_light),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(name, v, "a finite weight >= 0"));
            }
        }
        if let Some(o) = &self.outline {
            if !(o.width.is_finite() && o.width > 0.0 && o.width <= 16.0) {
                return Err(bad(
                    "outline width",
                    o.width,
                    "a width in pixels in (0, 16]",
                ));
            }
            if !o.crease_angle_deg.is_finite() {
                return Err(bad(
                    "outline crease angle",
                    o.crease_angle_deg,
                    "a finite angle in degrees",
                ));
            }
            if !(o.depth_gap.is_finite() && o.depth_gap > 0.0) {
                return Err(bad(
                    "outline depth gap",
                    o.depth_gap,
                    "a fraction of the diameter > 0",
                ));
            }
        }
        Ok(())
    }
}
