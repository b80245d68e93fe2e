//! The orthographic camera: view frame from azimuth, elevation and up axis, fitted to the
//! bounding sphere of the vertices the faces use.

use keycomp_mesh::{Mesh, Point3, Vector3};

use crate::error::RenderError;
use crate::params::{RenderParams, UpAxis};

/// Orthographic camera mapping world points to sample coordinates: `x` to the right and `y`
/// down in samples (sample `(i, j)` has its centre at `(i + 0.5, j + 0.5)`), depth in the same
/// units, smaller = nearer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Camera {
    center: Vector3<f64>,
    /// Unit vectors of the view frame in world coordinates: image right, image up, and towards
    /// the viewer (`right × up = toward`).
    pub right: Vector3<f64>,
    pub up: Vector3<f64>,
    pub toward: Vector3<f64>,
    /// Samples per world unit.
    pub scale: f64,
    /// Half the sample grid's side (the image centre in sample coordinates).
    half: f64,
    /// Bounding-sphere radius in world units.
    pub radius: f64,
}

impl Camera {
    /// Builds the view frame and fits the bounding sphere of the vertices faces use into a grid
    /// of `samples × samples` with the margin of `params`. Errors on a non-finite used vertex.
    pub fn fit(mesh: &Mesh, params: &RenderParams, samples: u32) -> Result<Camera, RenderError> {
        let (right0, up, toward0) = match params.up {
            UpAxis::Y => (Vector3::x(), Vector3::y(), Vector3::z()),
            UpAxis::Z => (Vector3::x(), Vector3::z(), -Vector3::y()),
        };
        let (az, el) = (
            params.azimuth_deg.to_radians(),
            params.elevation_deg.to_radians(),
        );
        let toward = (right0 * az.sin() + toward0 * az.cos()) * el.cos() + up * el.sin();
        let right = right0 * az.cos() - toward0 * az.sin();
        let up = toward.cross(&right).normalize();

        // Bounding sphere: centre of the bounding box, radius to the farthest used vertex.
        let mut used = vec![false; mesh.positions.len()];
        let mut min = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut max = -min;
        for f in &mesh.faces {
            for &v in f {
                let p = mesh.positions[v as usize];
                if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                    return Err(RenderError::NonFinite { vertex: v });
                }
                used[v as usize] = true;
                min = min.inf(&p);
                max = max.sup(&p);
            }
        }
        let center = if min.x <= max.x {
            nalgebra::center(&min, &max).coords
        } else {
            Vector3::zeros()
        };
        let radius = mesh
            .positions
            .iter()
            .zip(&used)
            .filter(|(_, u)| **u)
            .map(|(p, _)| (p.coords - center).norm())
            .fold(0.0, f64::max);
        let radius = if radius > 0.0 && radius.is_finite() {
            radius
        } else {
            1.0
        };
        let half = samples as f64 / 2.0;
        Ok(Camera {
            center,
            right,
            up,
            toward,
            scale: half * (1.0 - 2.0 * params.margin) / radius,
            half,
            radius,
        })
    }

    /// Sample coordinates `[x, y, depth]` of a world point.
    #[inline]
    pub fn project(&self, p: &Point3<f64>) -> [f64; 3] {
        let q = p.coords - self.center;
        [
            self.half + self.scale * q.dot(&self.right),
            self.half - self.scale * q.dot(&self.up),
            -self.scale * q.dot(&self.toward),
        ]
    }

    /// A world direction expressed in the view frame `[right, up, toward]`.
    #[inline]
    pub fn view_direction(&self, v: &Vector3<f64>) -> [f32; 3] {
        [
            v.dot(&self.right) as f32,
            v.dot(&self.up) as f32,
            v.dot(&self.toward) as f32,
        ]
    }
}
