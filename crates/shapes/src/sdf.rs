//! Implicit primitives and their smooth union: the signed-distance-like fields the shapes are
//! made of (negative inside, positive outside, zero on the surface).
//!
//! - Ellipsoid: the bound of I. Quílez ("Ellipsoid SDF", iquilezles.org, 2008),
//!   `d = k0·(k0 − 1)/k1` with `k0 = |q/r|`, `k1 = |q/r²|` in the ellipsoid's frame. It is exact
//!   on the surface and has the right sign everywhere.
//! - Capsule (tapered): the distance to the segment `ab` minus a radius interpolated linearly
//!   from `ra` at `a` to `rb` at `b` (exact for equal radii).
//! - Smooth union: the polynomial smooth minimum
//!   `smin(a, b; k) = min(a, b) − h²·k/4` with `h = max(k − |a − b|, 0)/k` (I. Quílez, "Smooth
//!   minimum", 2013): equal to `min` where the two fields differ by more than `k`, a fillet of
//!   width about `k` where they meet, so parts join without creases.

use keycomp_mesh::{Point3, Vector3};
use nalgebra::Rotation3;

/// One solid primitive.
#[derive(Debug, Clone, PartialEq)]
pub enum Primitive {
    /// An ellipsoid with semi-axes `radii` along the columns of `frame` (a rotation).
    Ellipsoid {
        /// Centre.
        center: Point3<f64>,
        /// Semi-axis lengths (all > 0), in the local frame.
        radii: Vector3<f64>,
        /// Rotation from local to world coordinates.
        frame: Rotation3<f64>,
    },
    /// A capsule around the segment `a`–`b`, radius `ra` at `a` tapering linearly to `rb` at `b`.
    Capsule {
        /// First end.
        a: Point3<f64>,
        /// Second end.
        b: Point3<f64>,
        /// Radius at `a` (> 0).
        ra: f64,
        /// Radius at `b` (> 0).
        rb: f64,
    },
}

impl Primitive {
    /// The field at `p`: negative inside, positive outside, zero on the surface.
    pub fn field(&self, p: &Point3<f64>) -> f64 {
        match self {
            Primitive::Ellipsoid {
                center,
                radii,
                frame,
            } => {
                let q = frame.inverse_transform_vector(&(p - center));
                let k0 = q.component_div(radii).norm();
                let k1 = q.component_div(&radii.component_mul(radii)).norm();
                if k1 < 1e-300 {
                    -radii.min()
                } else {
                    k0 * (k0 - 1.0) / k1
                }
            }
            Primitive::Capsule { a, b, ra, rb } => {
                let ab = b - a;
                let len2 = ab.norm_squared();
                let t = if len2 > 0.0 {
                    ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (p - (a + ab * t)).norm() - (ra + t * (rb - ra))
            }
        }
    }

    /// An axis-aligned box containing the primitive: `(min, max)`.
    pub fn bounds(&self) -> (Point3<f64>, Point3<f64>) {
        match self {
            Primitive::Ellipsoid { center, radii, .. } => {
                let r = Vector3::repeat(radii.max());
                (center - r, center + r)
            }
            Primitive::Capsule { a, b, ra, rb } => {
                let r = Vector3::repeat(ra.max(*rb));
                (a.inf(b) - r, a.sup(b) + r)
            }
        }
    }
}

/// Polynomial smooth minimum of `a` and `b` with blend width `k` (`k ≤ 0` gives `min`).
pub fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// A solid: the smooth union of primitives.
#[derive(Debug, Clone, PartialEq)]
pub struct Solid {
    /// The primitives, blended in this order.
    pub primitives: Vec<Primitive>,
    /// Blend width `k` of [`smooth_min`] (same unit as the coordinates).
    pub blend: f64,
}

impl Solid {
    /// The field of the smooth union at `p`.
    pub fn field(&self, p: &Point3<f64>) -> f64 {
        let mut d = f64::INFINITY;
        for prim in &self.primitives {
            let di = prim.field(p);
            d = if d.is_finite() {
                smooth_min(d, di, self.blend)
            } else {
                di
            };
        }
        d
    }

    /// A box containing the solid (the primitives' boxes, grown by the blend width).
    pub fn bounds(&self) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::from(Vector3::repeat(f64::INFINITY));
        let mut hi = Point3::from(Vector3::repeat(f64::NEG_INFINITY));
        for p in &self.primitives {
            let (a, b) = p.bounds();
            lo = lo.inf(&a);
            hi = hi.sup(&b);
        }
        let g = Vector3::repeat(self.blend.max(0.0));
        (lo - g, hi + g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_fields_are_exact_distances() {
        let e = Primitive::Ellipsoid {
            center: Point3::new(1.0, 0.0, 0.0),
            radii: Vector3::repeat(2.0),
            frame: Rotation3::identity(),
        };
        let c = Primitive::Capsule {
            a: Point3::new(1.0, 0.0, 0.0),
            b: Point3::new(1.0, 0.0, 0.0),
            ra: 2.0,
            rb: 2.0,
        };
        for p in [
            Point3::new(4.0, 0.0, 0.0),
            Point3::new(1.0, 0.5, 0.0),
            Point3::new(-3.0, 1.0, 2.0),
        ] {
            let exact = (p - Point3::new(1.0, 0.0, 0.0)).norm() - 2.0;
            assert!((e.field(&p) - exact).abs() < 1e-12);
            assert!((c.field(&p) - exact).abs() < 1e-12);
        }
    }

    #[test]
    fn ellipsoid_zero_on_its_surface_and_rotated() {
        let frame = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.7);
        let radii = Vector3::new(3.0, 1.0, 0.5);
        let e = Primitive::Ellipsoid {
            center: Point3::origin(),
            radii,
            frame,
        };
        for local in [Vector3::new(3.0, 0.0, 0.0), Vector3::new(0.0, 0.0, -0.5)] {
            let p = Point3::from(frame * local);
            assert!(e.field(&p).abs() < 1e-12);
            assert!(e.field(&Point3::from(frame * (local * 1.1))) > 0.0);
            assert!(e.field(&Point3::from(frame * (local * 0.9))) < 0.0);
        }
    }

    #[test]
    fn smooth_min_is_min_far_apart_and_below_min_near() {
        assert_eq!(smooth_min(1.0, 5.0, 0.5), 1.0);
        assert_eq!(smooth_min(1.0, 5.0, 0.0), 1.0);
        let s = smooth_min(1.0, 1.0, 0.4);
        assert!((s - (1.0 - 0.1)).abs() < 1e-12);
        assert!(smooth_min(1.0, 1.2, 0.4) < 1.0);
    }
}
