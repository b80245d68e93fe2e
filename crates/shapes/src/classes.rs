//! The shape classes: each a parametric skeleton of primitives whose proportions, limb
//! lengths, thicknesses and pose angles are drawn from a seeded generator. Coordinates are in
//! the model frame (y up, x forward), before the random rigid motion of [`crate::generate`].

use std::f64::consts::{PI, TAU};

use keycomp_mesh::{Point3, Vector3};
use nalgebra::Rotation3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::sdf::{Primitive, Solid};

/// A class of the built-in collection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Class {
    /// Four legs, a body, neck, head and tail.
    Quadruped,
    /// Two legs, two arms, torso, neck and head.
    Humanoid,
    /// Body, head and beak, two broad wings, a fanned tail.
    Bird,
    /// A mantle with six curling tentacles.
    Octopus,
    /// A long body on a sine wave with a head.
    Snake,
    /// A tapered cup with a handle (genus 1).
    Mug,
    /// A fish: body, forked tail fin, dorsal and side fins.
    Fish,
}

impl Class {
    /// Every class, in the collection's order.
    pub const ALL: [Class; 7] = [
        Class::Quadruped,
        Class::Humanoid,
        Class::Bird,
        Class::Octopus,
        Class::Snake,
        Class::Mug,
        Class::Fish,
    ];

    /// Lower-case name, used in file names (`quadruped-03`).
    pub fn name(self) -> &'static str {
        match self {
            Class::Quadruped => "quadruped",
            Class::Humanoid => "humanoid",
            Class::Bird => "bird",
            Class::Octopus => "octopus",
            Class::Snake => "snake",
            Class::Mug => "mug",
            Class::Fish => "fish",
        }
    }

    /// Parses [`Class::name`].
    pub fn from_name(s: &str) -> Option<Class> {
        Class::ALL.into_iter().find(|c| c.name() == s)
    }

    /// Genus of the surface (handles): 1 for the mug, 0 otherwise.
    pub fn genus(self) -> i64 {
        match self {
            Class::Mug => 1,
            _ => 0,
        }
    }

    /// The class's solid for one draw of its parameters.
    pub fn solid(self, rng: &mut ChaCha8Rng) -> Solid {
        let mut b = Builder {
            prims: Vec::new(),
            rng,
        };
        let blend = match self {
            Class::Quadruped => b.quadruped(),
            Class::Humanoid => b.humanoid(),
            Class::Bird => b.bird(),
            Class::Octopus => b.octopus(),
            Class::Snake => b.snake(),
            Class::Mug => b.mug(),
            Class::Fish => b.fish(),
        };
        Solid {
            primitives: b.prims,
            blend,
        }
    }
}

impl std::fmt::Display for Class {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Tentacles of the octopus class (six: with eight, neighbouring arms blend into webs
/// that can close into tunnels at coarse resolutions).
const ARMS: usize = 6;

struct Builder<'r> {
    prims: Vec<Primitive>,
    rng: &'r mut ChaCha8Rng,
}

fn p(x: f64, y: f64, z: f64) -> Point3<f64> {
    Point3::new(x, y, z)
}

/// Unit vector with azimuth `yaw` (about y, from +x towards +z) and elevation `pitch`.
fn dir(yaw: f64, pitch: f64) -> Vector3<f64> {
    Vector3::new(
        pitch.cos() * yaw.cos(),
        pitch.sin(),
        pitch.cos() * yaw.sin(),
    )
}

/// Rotation turning the local x axis onto `d` (then rolled by `roll` about it).
fn frame_along(d: Vector3<f64>, roll: f64) -> Rotation3<f64> {
    let base = Rotation3::rotation_between(&Vector3::x(), &d)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::y_axis(), PI));
    base * Rotation3::from_axis_angle(&Vector3::x_axis(), roll)
}

impl Builder<'_> {
    fn r(&mut self, lo: f64, hi: f64) -> f64 {
        self.rng.random_range(lo..hi)
    }
    fn capsule(&mut self, a: Point3<f64>, b: Point3<f64>, ra: f64, rb: f64) {
        self.prims.push(Primitive::Capsule { a, b, ra, rb });
    }
    fn ellipsoid(&mut self, center: Point3<f64>, radii: Vector3<f64>, frame: Rotation3<f64>) {
        self.prims.push(Primitive::Ellipsoid {
            center,
            radii,
            frame,
        });
    }
    /// Capsules through `points`, radius tapering linearly from `r0` to `r1`.
    fn chain(&mut self, points: &[Point3<f64>], r0: f64, r1: f64) {
        let n = points.len().saturating_sub(1).max(1) as f64;
        for (i, w) in points.windows(2).enumerate() {
            let ra = r0 + (r1 - r0) * i as f64 / n;
            let rb = r0 + (r1 - r0) * (i + 1) as f64 / n;
            self.capsule(w[0], w[1], ra, rb);
        }
    }

    fn quadruped(&mut self) -> f64 {
        let len = self.r(1.6, 2.3);
        let leg = self.r(0.7, 1.1);
        let (ry, rz) = (self.r(0.3, 0.42), self.r(0.28, 0.36));
        let body = p(0.0, leg + 0.15, 0.0);
        self.ellipsoid(body, Vector3::new(len / 2.0, ry, rz), Rotation3::identity());
        let thick = self.r(0.09, 0.13);
        for (sx, sz) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let hip = p(sx * 0.33 * len, leg, sz * 0.55 * rz);
            let swing = self.r(-0.3, 0.3);
            let knee_bend = self.r(0.0, 0.25) * -sx;
            let knee = p(hip.x + swing * 0.5 + knee_bend, leg * 0.5, hip.z * 1.1);
            let foot = p(hip.x + swing, 0.0, hip.z * 1.2);
            self.chain(&[hip, knee, foot], thick, thick * 0.75);
        }
        let neck_len = self.r(0.4, 0.8);
        let neck_pitch = self.r(0.5, 1.2);
        let n0 = p(0.42 * len, leg + 0.25, 0.0);
        let n1 = n0 + dir(0.0, neck_pitch) * neck_len;
        self.capsule(n0, n1, 0.15, 0.11);
        let head_pitch = self.r(-0.6, 0.1);
        let head_len = self.r(0.22, 0.32);
        self.ellipsoid(
            n1 + dir(0.0, head_pitch) * head_len * 0.6,
            Vector3::new(head_len, 0.14, 0.13),
            frame_along(dir(0.0, head_pitch), 0.0),
        );
        let tail_pitch = self.r(-0.8, 0.6);
        let tail_len = self.r(0.4, 0.8);
        let t0 = p(-0.45 * len, leg + 0.25, 0.0);
        let t1 = t0 + dir(PI, tail_pitch) * tail_len * 0.5;
        let curl = self.r(-0.6, 0.6);
        let t2 = t1 + dir(PI, tail_pitch + curl) * tail_len * 0.5;
        self.chain(&[t0, t1, t2], 0.09, 0.07);
        0.1
    }

    fn humanoid(&mut self) -> f64 {
        let leg = self.r(0.8, 1.05);
        let stance = self.r(0.1, 0.22);
        let torso_h = self.r(0.28, 0.38);
        let (tw, td) = (self.r(0.2, 0.27), self.r(0.13, 0.16));
        let thick = self.r(0.08, 0.1);
        for s in [1.0, -1.0] {
            let hip = p(0.0, leg, s * 0.11);
            let stride = self.r(-0.35, 0.35);
            let knee = p(
                stride * 0.5 + self.r(0.0, 0.12),
                leg * 0.5,
                s * (0.11 + stance * 0.5),
            );
            let foot = p(stride, 0.0, s * (0.11 + stance));
            self.chain(&[hip, knee, foot], thick * 1.2, thick);
            self.ellipsoid(
                foot + Vector3::new(0.08, 0.0, 0.0),
                Vector3::new(0.14, 0.07, 0.08),
                Rotation3::identity(),
            );
        }
        let chest = p(0.0, leg + torso_h, 0.0);
        let lean = self.r(-0.15, 0.15);
        self.ellipsoid(
            chest,
            Vector3::new(td, torso_h, tw),
            Rotation3::from_axis_angle(&Vector3::z_axis(), lean),
        );
        let neck_top = chest + Vector3::new(0.0, torso_h + 0.12, 0.0);
        self.capsule(chest, neck_top, 0.07, 0.07);
        let head_r = self.r(0.11, 0.15);
        self.ellipsoid(
            neck_top + Vector3::new(0.0, head_r * 0.8, 0.0),
            Vector3::new(head_r * 1.1, head_r * 1.25, head_r),
            Rotation3::identity(),
        );
        let arm = self.r(0.55, 0.75);
        for s in [1.0, -1.0] {
            let shoulder = chest + Vector3::new(0.0, torso_h * 0.7, s * tw * 0.9);
            // abduction from hanging down (0) to raised sideways (≈ 1.6)
            let abduct = self.r(0.2, 1.7);
            let forward = self.r(-0.6, 0.6);
            let d1 = Vector3::new(forward.sin(), -abduct.cos(), s * abduct.sin()).normalize();
            let elbow = shoulder + d1 * arm * 0.5;
            let bend = self.r(0.0, 1.2);
            let d2 = (d1 + Vector3::new(bend, bend * 0.3, 0.0)).normalize();
            let hand = elbow + d2 * arm * 0.5;
            self.chain(&[shoulder, elbow, hand], thick * 0.9, thick * 0.75);
        }
        0.08
    }

    fn bird(&mut self) -> f64 {
        let bl = self.r(0.45, 0.6);
        let radii = Vector3::new(bl, self.r(0.22, 0.3), self.r(0.22, 0.28));
        self.ellipsoid(p(0.0, 0.0, 0.0), radii, Rotation3::identity());
        let hr = self.r(0.14, 0.19);
        // The head sits on the body's front (overlapping it), so no gap can close into a loop.
        let head = p(bl * 0.8, radii.y * 0.45 + hr * 0.5, 0.0);
        self.ellipsoid(head, Vector3::repeat(hr), Rotation3::identity());
        let beak_pitch = self.r(-0.5, 0.2);
        let beak_len = self.r(0.18, 0.35);
        self.capsule(
            head + dir(0.0, beak_pitch) * hr * 0.6,
            head + dir(0.0, beak_pitch) * (hr + beak_len),
            0.07,
            0.05,
        );
        let span = self.r(0.6, 0.95);
        let chord = self.r(0.2, 0.3);
        let flap = self.r(-0.3, 0.7);
        let sweep = self.r(-0.3, 0.3);
        for s in [1.0, -1.0] {
            let d = dir(s * (PI / 2.0 + sweep), flap);
            let root = p(0.05, 0.1, s * 0.15);
            self.ellipsoid(
                root + d * span,
                Vector3::new(span, chord, 0.09),
                frame_along(d, s * PI / 2.0),
            );
        }
        let tail_pitch = self.r(-0.3, 0.4);
        let td = dir(PI, tail_pitch);
        let radii = Vector3::new(self.r(0.25, 0.35), 0.09, self.r(0.14, 0.2));
        self.ellipsoid(
            p(-bl * 0.8, 0.05, 0.0) + td * 0.25,
            radii,
            frame_along(td, 0.0),
        );
        0.08
    }

    fn octopus(&mut self) -> f64 {
        let mh = self.r(0.5, 0.75);
        let mr = self.r(0.35, 0.45);
        let tilt = self.r(-0.3, 0.3);
        self.ellipsoid(
            p(0.0, 0.35 + mh * 0.8, 0.0),
            Vector3::new(mr, mh, mr),
            Rotation3::from_axis_angle(&Vector3::z_axis(), tilt),
        );
        let spin = self.r(0.0, TAU);
        let seg = self.r(0.24, 0.34);
        for i in 0..ARMS {
            let yaw = spin + TAU * i as f64 / ARMS as f64 + self.r(-0.1, 0.1);
            // The base is inside the mantle so neighbouring arms part below it.
            let mut pos = p(0.15 * yaw.cos(), 0.5, 0.15 * yaw.sin());
            let mut pitch = self.r(-0.9, -0.4);
            let curl = self.r(-0.1, 0.3);
            let mut pts = vec![pos];
            for _ in 0..4 {
                pos += dir(yaw, pitch) * seg;
                pts.push(pos);
                pitch += curl;
            }
            self.chain(&pts, 0.13, 0.085);
        }
        0.07
    }

    fn snake(&mut self) -> f64 {
        let len = self.r(3.0, 4.0);
        let amp = self.r(0.2, 0.4);
        let wave = self.r(1.3, 2.0);
        let phase = self.r(0.0, TAU);
        let lift = self.r(0.0, 0.35);
        let r = self.r(0.11, 0.14);
        let n = 14;
        let pts: Vec<Point3<f64>> = (0..=n)
            .map(|i| {
                let x = len * i as f64 / n as f64;
                p(x, 0.0, amp * (TAU * x / wave + phase).sin())
            })
            .collect();
        self.chain(&pts, 0.07, r);
        let neck = pts[n];
        let head_dir = dir(self.r(-0.4, 0.4), 0.0);
        let head = neck + head_dir * 0.25 + Vector3::new(0.0, lift, 0.0);
        self.capsule(neck, head, r, r);
        self.ellipsoid(
            head + head_dir * 0.12,
            Vector3::new(0.26, r * 1.1, r * 1.4),
            frame_along(head_dir, 0.0),
        );
        0.08
    }

    fn mug(&mut self) -> f64 {
        let h = self.r(0.8, 1.2);
        let (r0, r1) = (self.r(0.35, 0.5), self.r(0.35, 0.5));
        self.capsule(p(0.0, r0, 0.0), p(0.0, r0 + h, 0.0), r0, r1);
        let mid = r0 + h * self.r(0.4, 0.6);
        let rh = self.r(0.28, 0.38);
        let th = self.r(0.07, 0.09);
        let r_mid = r0 + (r1 - r0) * ((mid - r0) / h);
        let centre = p(r_mid * 0.95, mid, 0.0);
        let n = 10;
        let pts: Vec<Point3<f64>> = (0..=n)
            .map(|i| {
                let a = -PI / 2.0 + PI * i as f64 / n as f64;
                centre + Vector3::new(rh * a.cos(), rh * a.sin(), 0.0)
            })
            .collect();
        self.chain(&pts, th, th);
        // A foot ring so the base has a rim.
        self.ellipsoid(
            p(0.0, 0.05, 0.0),
            Vector3::new(r0 * 0.95, 0.08, r0 * 0.95),
            Rotation3::identity(),
        );
        0.07
    }

    fn fish(&mut self) -> f64 {
        let bl = self.r(0.7, 1.0);
        let bh = self.r(0.25, 0.4);
        let bend = self.r(-0.4, 0.4);
        let radii = Vector3::new(bl, bh, self.r(0.14, 0.2));
        self.ellipsoid(p(0.0, 0.0, 0.0), radii, Rotation3::identity());
        let td = dir(PI + bend, 0.0);
        let root = p(-bl * 0.85, 0.0, 0.0);
        self.capsule(p(-bl * 0.5, 0.0, 0.0), root + td * 0.15, 0.12, 0.08);
        let fork = self.r(0.35, 0.7);
        let fin = self.r(0.3, 0.45);
        for s in [1.0, -1.0] {
            let d = (td + Vector3::new(0.0, s * fork, 0.0)).normalize();
            self.ellipsoid(
                root + td * 0.15 + d * fin,
                Vector3::new(fin, 0.1, 0.085),
                frame_along(d, 0.0),
            );
        }
        let dorsal = self.r(0.25, 0.4);
        let dd = dir(PI, self.r(0.6, 1.2));
        self.ellipsoid(
            p(0.0, bh * 0.8, 0.0) + dd * dorsal * 0.6,
            Vector3::new(dorsal, 0.12, 0.085),
            frame_along(dd, 0.0),
        );
        let side = self.r(0.18, 0.3);
        for s in [1.0, -1.0] {
            let d = dir(s * self.r(2.0, 2.6), -0.4);
            self.ellipsoid(
                p(bl * 0.35, -bh * 0.4, s * 0.12) + d * side,
                Vector3::new(side, 0.085, 0.11),
                frame_along(d, 0.0),
            );
        }
        0.07
    }
}
