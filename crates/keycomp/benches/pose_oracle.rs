//! The pose oracle: pieces cut from real shapes and moved by known random similarities, matched
//! back onto their shape; how far the transform keycomp gives is from the truth.
//!
//! `cargo bench -p keycomp --bench pose_oracle -- [--cases N] [--seed S] FOLDER...`
//! (FOLDERs relative to the workspace root; when `cargo bench` did not run it, it prints its
//! usage and measures nothing)
//!
//! Each case (seeded, `--cases` of them, default 100) draws a mesh of the folders, a kind (a
//! geodesic ball, a plane cut or a one-sided scan view, `keycomp_fragment`) keeping 20–60 % of
//! its area, a uniformly random rotation, a scale in [0.5, 2] (log-uniform) and a translation
//! of up to twice the shape's size; the moved piece is matched onto the shape
//! (`keycomp::matching::match_analysed`, the default profile). Measured per case: the rotation
//! error (degrees), the scale error (%), the median displacement of the piece's vertices from
//! where they were cut (% of the shape's bounding-box diagonal), whether a transform was given
//! at all, and where the transform puts the piece: the median distance of its moved vertices to
//! the shape (to the nearest of 100,000 points drawn by area on it, % of the diagonal). A pose
//! is *right* within 2° and 1 % displacement. A wrong one is *right up to a symmetry of the
//! shape* when the map it implies from where the piece was cut to where it was put (the truth,
//! then the pose) is a symmetry of the whole shape: 5,000 of the shape's samples moved by it lie
//! on the shape (90th percentile of their distances ≤ 1 % of the diagonal, scale within 1 %),
//! so that no method could tell the two poses apart (a table's four legs, a vase turned about
//! its axis). Else a pose that still lays the piece on the shape (median distance ≤ 0.5 %) put
//! it on another place the piece fits; else it is *off* the shape. Prints one line per case,
//! the four counts, and the median, 90th and 95th percentiles of the errors, as measured and
//! with the poses right up to a symmetry counted as right (error 0).

use std::path::PathBuf;

use keycomp::matching::{MatchParams, match_analysed};
use keycomp::{Profile, Role, analyse_mesh, analyse_mesh_as};
use keycomp_fragment::{PartialKind, cut_fragment};
use keycomp_mesh::sample::AreaSampler;
use keycomp_mesh::{Point3, Vector3, geometry, read_mesh};
use keycomp_test_support::{bench_args, median, quantile, take_number, workspace_path};
use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use nalgebra::{Matrix3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Points drawn by area on the shape, the distance to the nearest of which stands for the
/// distance to the shape.
const SHAPE_SAMPLES: usize = 100_000;
/// Median distance (% of the diagonal) under which a moved piece lies on its shape.
const ON_SHAPE: f64 = 0.5;

/// Largest 90th percentile of the distances (% of the diagonal) from the shape, moved by the
/// map a wrong pose implies from the piece's place to where it was put, to the shape: under
/// it, that map is a symmetry of the shape and the pose is as right as the truth.
const SYMMETRY: f64 = 1.0;
/// Largest scale error (%) of a symmetry.
const SYMMETRY_SCALE: f64 = 1.0;
/// Shape samples moved by that map.
const SYMMETRY_SAMPLES: usize = 5_000;

/// `SHAPE_SAMPLES` points drawn by area on a shape, with a KD-tree over them: the distance to
/// the nearest stands for the distance to the shape.
struct ShapeSamples {
    coords: Vec<[f64; 3]>,
    tree: ImmutableKdTree<f64, u32, 3, 32>,
}

impl ShapeSamples {
    /// The samples of `mesh` (seeded by `seed`); `None` for a mesh without area.
    fn new(mesh: &keycomp_mesh::Mesh, seed: u64) -> Option<Self> {
        let sampler = AreaSampler::new(mesh)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let coords: Vec<[f64; 3]> = (0..SHAPE_SAMPLES)
            .map(|_| {
                let p = sampler.sample(&mut rng).0;
                [p.x, p.y, p.z]
            })
            .collect();
        let tree = ImmutableKdTree::new_from_slice(&coords);
        Some(ShapeSamples { coords, tree })
    }

    /// The distance from `p` to the shape.
    fn distance(&self, p: &Point3<f64>) -> f64 {
        self.tree
            .nearest_one::<SquaredEuclidean>(&[p.x, p.y, p.z])
            .distance
            .sqrt()
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "cargo bench -p keycomp --bench pose_oracle -- [--cases N] [--seed S] FOLDER...";
    let Some(mut args) = bench_args(usage) else {
        return Ok(());
    };
    args.remove(0);
    let cases: usize = take_number(&mut args, "--cases")?.unwrap_or(100);
    let seed: u64 = take_number(&mut args, "--seed")?.unwrap_or(0);
    let mut files: Vec<PathBuf> = Vec::new();
    for folder in &args {
        let mut f: Vec<PathBuf> = std::fs::read_dir(workspace_path(folder))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| keycomp_mesh::Format::from_path(p).is_ok())
            .collect();
        f.sort();
        files.extend(f);
    }
    if files.is_empty() {
        return Err(usage.into());
    }
    let profile = Profile::current(&keycomp::options::DetectOptions::default().retrieval_params());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut rot, mut scale, mut disp) = (Vec::new(), Vec::new(), Vec::new());
    let (mut rot_sym, mut scale_sym, mut disp_sym) = (Vec::new(), Vec::new(), Vec::new());
    let mut missing = 0;
    let (mut right, mut symmetric_right, mut elsewhere, mut off) = (0, 0, 0, 0);
    println!(
        "case | shape | kind | kept | rotation ° | scale % | displacement % of diagonal | on the shape: median distance % | pose"
    );
    for case in 0..cases {
        let file = &files[rng.random_range(0..files.len())];
        let kind =
            [PartialKind::Ball, PartialKind::Plane, PartialKind::Scan][rng.random_range(0..3)];
        let fraction = rng.random_range(0.2..0.6);
        let truth_r = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ))
        .to_rotation_matrix();
        let truth_s: f64 = 2f64.powf(rng.random_range(-1.0..1.0));
        let mesh = read_mesh(file)?.mesh;
        let diag = geometry::bounding_box(&mesh).diagonal();
        let shift = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * 2.0
            * diag;
        let mut frng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1000) + case as u64);
        let Ok(piece) = cut_fragment(&mesh, kind, fraction, &mut frng) else {
            continue;
        };
        let mut moved = piece.mesh.clone();
        for p in &mut moved.positions {
            *p = Point3::from(truth_r * p.coords * truth_s + shift);
        }
        let q = analyse_mesh_as(moved.clone(), &profile, Role::Query)?;
        let t = analyse_mesh(mesh.clone(), &profile)?;
        let params = MatchParams {
            verify_weight: q.verify_weight(None),
            ..MatchParams::default()
        };
        let m = match_analysed(&q, &t, ("piece", "shape"), &params);
        let name = file
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Some(tr) = m.transform else {
            missing += 1;
            println!(
                "{case} | {name} | {kind:?} | {:.2} | - | - | -",
                piece.fraction
            );
            continue;
        };
        let r = Matrix3::from_fn(|i, j| tr.rotation[i][j]);
        let d = r * truth_r.matrix();
        let angle = ((d.trace() - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        let s_err = 100.0 * (tr.scale * truth_s - 1.0).abs();
        let offs: Vec<f64> = moved
            .positions
            .iter()
            .zip(&piece.mesh.positions)
            .map(|(p, o)| {
                let x = tr.apply([p.x, p.y, p.z]);
                (Point3::new(x[0], x[1], x[2]) - o).norm()
            })
            .collect();
        let med = 100.0 * median(offs) / diag;
        let placed: Vec<Point3<f64>> = moved
            .positions
            .iter()
            .map(|p| Point3::from(tr.apply([p.x, p.y, p.z])))
            .collect();
        let Some(shape) = ShapeSamples::new(&mesh, case as u64) else {
            continue;
        };
        let on = 100.0 * median(placed.iter().map(|p| shape.distance(p)).collect()) / diag;
        // the map from where the piece was cut to where the pose put it: a symmetry of the
        // shape when it moves the whole shape onto itself
        let symmetry = |p: &[f64; 3]| {
            let x = truth_r * Vector3::new(p[0], p[1], p[2]) * truth_s + shift;
            Point3::from(tr.apply([x.x, x.y, x.z]))
        };
        let step = (SHAPE_SAMPLES / SYMMETRY_SAMPLES).max(1);
        let mut moved_shape: Vec<f64> = shape
            .coords
            .iter()
            .step_by(step)
            .map(|p| shape.distance(&symmetry(p)))
            .collect();
        moved_shape.sort_by(f64::total_cmp);
        let symmetric =
            s_err <= SYMMETRY_SCALE && 100.0 * quantile(&moved_shape, 0.9) / diag <= SYMMETRY;
        let pose = if angle <= 2.0 && med <= 1.0 {
            right += 1;
            "right"
        } else if symmetric {
            symmetric_right += 1;
            "right up to a symmetry of the shape"
        } else if on <= ON_SHAPE {
            elsewhere += 1;
            "on the shape elsewhere"
        } else {
            off += 1;
            "off the shape"
        };
        println!(
            "{case} | {name} | {kind:?} | {:.2} | {angle:.3} | {s_err:.3} | {med:.3} | {on:.3} | {pose}",
            piece.fraction
        );
        rot.push(angle);
        scale.push(s_err);
        disp.push(med);
        // up to symmetry: a pose as right as the truth counts as right
        let (r, sc, d) = if symmetric {
            (0.0, 0.0, 0.0)
        } else {
            (angle, s_err, med)
        };
        rot_sym.push(r);
        scale_sym.push(sc);
        disp_sym.push(d);
    }
    println!();
    println!(
        "{} cases, {} without a transform",
        rot.len() + missing,
        missing
    );
    println!(
        "right pose {right}, right up to a symmetry of the shape {symmetric_right}, on the shape elsewhere {elsewhere}, off the shape {off}, none {missing}"
    );
    println!("measure | median | 90th percentile | 95th percentile");
    for (name, v) in [
        ("rotation °", &mut rot),
        ("scale %", &mut scale),
        ("displacement % of diagonal", &mut disp),
        ("rotation °, up to symmetry", &mut rot_sym),
        ("scale %, up to symmetry", &mut scale_sym),
        ("displacement % of diagonal, up to symmetry", &mut disp_sym),
    ] {
        v.sort_by(f64::total_cmp);
        println!(
            "{name} | {:.3} | {:.3} | {:.3}",
            quantile(v, 0.5),
            quantile(v, 0.9),
            quantile(v, 0.95)
        );
    }
    Ok(())
}
