//! Where a query sits on a shape: the similarity transform taking the query's coordinates to
//! the shape's, in the files' own units, from the alignment geometric verification finds
//! (`keycomp_retrieval::verify`: RANSAC over matched part centres, M. A. Fischler and R. C.
//! Bolles, CACM 24(6), 1981; Umeyama's least-squares similarity, IEEE TPAMI 13(4), 1991; ICP,
//! P. J. Besl and N. D. McKay, IEEE TPAMI 14(2), 1992).
//!
//! Verification aligns the two shapes in their analysis frames: each analysed mesh scaled by
//! its frame factor c (1/√area of the mesh analysed when the scale is free, 1/L in file units
//! of length L), without translation. A frame alignment `y = s·R·x + t` between a query of
//! factor c_q and a shape of factor c_t is, in file coordinates,
//! `p' = (s·c_q/c_t)·R·p + t/c_t`.
//!
//! Conventions: column vectors; `rotation` and `matrix` are row-major (`matrix[i][j]` is row
//! i, column j), `matrix` the 4×4 homogeneous form `[s·R | t; 0 0 0 1]` acting on
//! `[x, y, z, 1]`; the query's coordinates are those of its file (a canonical surface lies on
//! its input, so a file and its surface share them), the shape's those of its file.

use keycomp_mesh::{Mesh, Point3};
use keycomp_retrieval::Alignment;
use serde::{Deserialize, Serialize};

/// Most of the query's input points the refinement moves (every k-th,
/// [`Transform::refined_best`]).
pub const REFINE_POINTS: usize = 4000;
/// Most of those moved when several candidates are compared (every k-th).
pub const QUICK_POINTS: usize = 250;
/// Rounds of refinement of each candidate when several are compared.
pub const QUICK_ROUNDS: usize = 8;

/// The similarity transform taking a query's file coordinates onto a shape's (see the module
/// documentation for the conventions).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Rotation, row-major.
    pub rotation: [[f64; 3]; 3],
    /// Translation, in the shape's file units.
    pub translation: [f64; 3],
    /// Uniform scale: shape length over query length (1 when both files share their units
    /// and the query is a piece of the shape).
    pub scale: f64,
    /// `[scale·rotation | translation; 0 0 0 1]`, row-major, on column vectors `[x, y, z, 1]`.
    pub matrix: [[f64; 4]; 4],
    /// The share of the query's surface sample that lies on the shape's once moved
    /// (verification's fitness).
    pub verified: f64,
    /// Root mean square of the point-to-plane distances from the query's surface to the
    /// shape's once refined ([`Transform::refined_best`]), in the shape's file units; `None` when the
    /// transform is verification's alone (not refined).
    pub rms: Option<f64>,
}

impl Transform {
    /// The file-coordinate transform of a frame alignment `a` between a query of frame factor
    /// `query_frame` and a shape of frame factor `target_frame` (module documentation);
    /// `None` when a factor is not a positive number.
    pub fn from_alignment(
        a: &Alignment,
        query_frame: f64,
        target_frame: f64,
        verified: f64,
    ) -> Option<Transform> {
        let ok = |c: f64| c.is_finite() && c > 0.0;
        if !(ok(query_frame) && ok(target_frame)) {
            return None;
        }
        let scale = a.scale * query_frame / target_frame;
        let translation = a.translation.map(|x| x / target_frame);
        let matrix = std::array::from_fn(|i| {
            if i == 3 {
                [0.0, 0.0, 0.0, 1.0]
            } else {
                let r = a.rotation[i];
                [scale * r[0], scale * r[1], scale * r[2], translation[i]]
            }
        });
        Some(Transform {
            rotation: a.rotation,
            translation,
            scale,
            matrix,
            verified,
            rms: None,
        })
    }

    /// The best of `candidates` (verification's alignment first, then its alternatives,
    /// [`crate::Analysed::transforms_onto`]), each refined on the surfaces
    /// (`keycomp_retrieval::refine`: trimmed point-to-plane ICP): `query`, points of the
    /// query's surface, onto `target`, the shape's mesh, both in their files' coordinates; the
    /// scale kept when `fixed_scale` (both in the same units). With several candidates each is
    /// refined [`QUICK_ROUNDS`] rounds on at most [`QUICK_POINTS`] of the points and the one that puts
    /// most of them on the shape (`keycomp_retrieval::refine::Target::on`; the earlier of
    /// equals) is refined fully. The first candidate as it is when refinement fails or the
    /// meshes are too small; `None` without candidates.
    pub fn refined_best(
        candidates: &[Transform],
        query: &[Point3<f64>],
        target: &Mesh,
        fixed_scale: bool,
    ) -> Option<Transform> {
        let step = query.len().div_ceil(REFINE_POINTS).max(1);
        let points: Vec<[f64; 3]> = query
            .iter()
            .step_by(step)
            .map(|p| [p.x, p.y, p.z])
            .collect();
        let normals = keycomp_mesh::geometry::vertex_normals(target);
        // vertices no face with an area uses have no normal: left out
        let (targets, normals): (Vec<[f64; 3]>, Vec<[f64; 3]>) = target
            .positions
            .iter()
            .zip(&normals)
            .filter(|(_, n)| n.norm_squared() > 0.0)
            .map(|(p, n)| ([p.x, p.y, p.z], [n.x, n.y, n.z]))
            .unzip();
        let Some(surface) = keycomp_retrieval::refine::Target::new(&targets, &normals) else {
            return candidates.first().copied();
        };
        let start = |c: &Transform| Alignment {
            rotation: c.rotation,
            translation: c.translation,
            scale: c.scale,
        };
        // several candidates: a first look at each (a few rounds on a few of the points), the
        // one that puts most of them on the shape refined fully from where that look left it
        let mut chosen = candidates.first().map(|c| (start(c), c.verified))?;
        if candidates.len() > 1 {
            let step = points.len().div_ceil(QUICK_POINTS).max(1);
            let few: Vec<[f64; 3]> = points.iter().step_by(step).copied().collect();
            let mut best = f64::NEG_INFINITY;
            for c in candidates {
                if let Some(r) = surface.refine(&few, start(c), fixed_scale, QUICK_ROUNDS) {
                    let on = surface.on(&few, &r.alignment);
                    if on > best {
                        best = on;
                        chosen = (r.alignment, c.verified);
                    }
                }
            }
        }
        let (from, verified) = chosen;
        match surface.refine(
            &points,
            from,
            fixed_scale,
            keycomp_retrieval::refine::ROUNDS,
        ) {
            Some(r) => Some(Transform {
                rms: Some(r.rms),
                ..Transform::from_alignment(&r.alignment, 1.0, 1.0, verified)?
            }),
            None => candidates.first().copied(),
        }
    }

    /// `p` (query file coordinates) moved onto the shape.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.matrix;
        std::array::from_fn(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
    }

    /// The rotation's angle, in degrees.
    pub fn angle_degrees(&self) -> f64 {
        let r = &self.rotation;
        let c = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
        c.acos().to_degrees()
    }
}

/// The frame factor of a mesh analysed with `units` whose analysed surface has `area` (file
/// units squared): 1/√area scale-free, 1/L in file units of length L.
pub fn frame_factor(units: keycomp_describe::Units, area: f64) -> f64 {
    match units {
        keycomp_describe::Units::ScaleFree => 1.0 / area.sqrt(),
        keycomp_describe::Units::File { length } => 1.0 / length,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The file-coordinate transform undoes both frames: a point of the query scaled by its
    /// factor, aligned, and scaled back by the shape's lands where the transform puts it.
    #[test]
    fn frames_compose() {
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let a = Alignment {
            rotation: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.1, -0.2, 0.05],
            scale: 0.8,
        };
        let (cq, ct) = (0.5, 0.02);
        let t = Transform::from_alignment(&a, cq, ct, 0.9).expect("valid factors");
        let p = [1.0, 2.0, -3.0];
        let in_frames = a.apply(p.map(|x| x * cq)).map(|y| y / ct);
        let direct = t.apply(p);
        for i in 0..3 {
            assert!(
                (in_frames[i] - direct[i]).abs() < 1e-9,
                "{in_frames:?} {direct:?}"
            );
        }
        assert!((t.scale - 0.8 * 0.5 / 0.02).abs() < 1e-12);
        assert!((t.angle_degrees() - 0.3f64.to_degrees()).abs() < 1e-9);
        assert!(Transform::from_alignment(&a, 0.0, ct, 0.9).is_none());
        assert!(Transform::from_alignment(&a, cq, f64::NAN, 0.9).is_none());
    }

    /// Of two starts, a pose turned half a turn (whose trimmed pairs still fit a bumpy
    /// surface's middle) and one a little off the truth, the refinement keeps the one that puts
    /// the points on the surface, and refines it to the truth; the order does not matter.
    #[test]
    fn the_best_of_several_starts_is_the_one_on_the_surface() {
        use keycomp_mesh::synth;
        let surface = synth::height_field(60, 60, 0.05, |x, y| {
            0.3 * (2.0 * x).sin() * (1.5 * y).cos() + 0.2 * x * x
        });
        // the query: the surface's vertices in a third of it, in their own file's frame (a
        // shift), so that the truth is a translation
        let shift = [0.4, -0.2, 0.1];
        let query: Vec<Point3<f64>> = surface
            .positions
            .iter()
            .filter(|p| p.x < -0.5)
            .map(|p| Point3::new(p.x - shift[0], p.y - shift[1], p.z - shift[2]))
            .collect();
        let at = |angle: f64, off: f64| {
            let (c, s) = (angle.cos(), angle.sin());
            let a = Alignment {
                rotation: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
                translation: [shift[0] + off, shift[1], shift[2]],
                scale: 1.0,
            };
            Transform::from_alignment(&a, 1.0, 1.0, 0.9).expect("valid")
        };
        let (turned, near) = (at(std::f64::consts::PI, 0.0), at(0.02, 0.03));
        for candidates in [[turned, near], [near, turned]] {
            let t =
                Transform::refined_best(&candidates, &query, &surface, true).expect("a transform");
            assert!(t.angle_degrees() < 0.1, "{t:?}");
            for (got, want) in t.translation.iter().zip(shift) {
                assert!((got - want).abs() < 1e-3, "{t:?}");
            }
        }
        assert!(Transform::refined_best(&[], &query, &surface, true).is_none());
    }

    /// The oracle: a piece cut from a shape and moved by a known similarity, matched back,
    /// gives a transform that takes it back where it was cut from, to a fraction of the
    /// sampling once refined (rotation within 0.5°, scale within 0.5 %, points within 0.2 % of
    /// the diagonal).
    #[test]
    fn a_moved_piece_is_put_back() {
        use crate::matching::{MatchParams, match_analysed};
        use crate::{Profile, Role, analyse_mesh, analyse_mesh_as};
        use keycomp_mesh::{Point3, Vector3, synth};
        use nalgebra::Rotation3;

        let whole = synth::textured_protrusion_sphere(5);
        let (piece, _) = keycomp_mesh::cut::cut_by_plane(
            &whole,
            Point3::new(0.0, 0.0, -0.2),
            Vector3::new(0.3, 0.2, 1.0).normalize(),
        );
        let rot = Rotation3::from_euler_angles(0.7, -0.4, 1.9);
        let (scale, shift) = (2.5, Vector3::new(10.0, -4.0, 7.0));
        let mut moved = piece.clone();
        for p in &mut moved.positions {
            *p = Point3::from(rot * p.coords * scale + shift);
        }
        let profile =
            Profile::current(&crate::options::DetectOptions::default().retrieval_params());
        let q = analyse_mesh_as(moved.clone(), &profile, Role::Query).expect("analyse");
        let t = analyse_mesh(whole.clone(), &profile).expect("analyse");
        let params = MatchParams {
            verify_weight: q.verify_weight(None),
            ..MatchParams::default()
        };
        let m = match_analysed(&q, &t, ("piece", "whole"), &params);
        let tr = m.transform.expect("an alignment");
        // the inverse of the move: scale 1/2.5, rotation back
        assert!((tr.scale * scale - 1.0).abs() < 0.005, "scale {}", tr.scale);
        let r = nalgebra::Matrix3::from_fn(|i, j| tr.rotation[i][j]);
        let d = r * rot.matrix();
        let err = ((d.trace() - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        assert!(err < 0.5, "rotation off by {err}°");
        // every moved vertex lands near where it was cut from
        let diag = keycomp_mesh::geometry::bounding_box(&whole).diagonal();
        let mut off: Vec<f64> = moved
            .positions
            .iter()
            .zip(&piece.positions)
            .map(|(p, o)| {
                let x = tr.apply([p.x, p.y, p.z]);
                (Point3::new(x[0], x[1], x[2]) - o).norm() / diag
            })
            .collect();
        off.sort_by(f64::total_cmp);
        assert!(
            off[off.len() / 2] < 0.002,
            "median displacement {}",
            off[off.len() / 2]
        );
        assert!(tr.rms.is_some_and(|r| r < 0.002 * diag), "{tr:?}");
        assert!(tr.verified > 0.7, "verified {}", tr.verified);
    }
}
