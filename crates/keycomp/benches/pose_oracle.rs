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
//! is *right* within 2° and 1 % displacement; a wrong one that still lays the piece on the
//! shape (median distance ≤ 0.5 %) put it on another place the piece fits, a symmetric
//! counterpart (a car's other side, a chair's other leg); else it is *off* the shape. Prints one
//! line per case, the three counts, and the median, 90th and 95th percentiles.

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

/// The median distance from `points` to the nearest of `SHAPE_SAMPLES` points drawn by area on
/// `mesh` (seeded by `seed`).
fn median_distance_to(mesh: &keycomp_mesh::Mesh, points: &[Point3<f64>], seed: u64) -> f64 {
    let Some(sampler) = AreaSampler::new(mesh) else {
        return f64::INFINITY;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let coords: Vec<[f64; 3]> = (0..SHAPE_SAMPLES)
        .map(|_| {
            let p = sampler.sample(&mut rng).0;
            [p.x, p.y, p.z]
        })
        .collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    median(
        points
            .iter()
            .map(|p| {
                tree.nearest_one::<SquaredEuclidean>(&[p.x, p.y, p.z])
                    .distance
                    .sqrt()
            })
            .collect(),
    )
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
    let mut missing = 0;
    let (mut right, mut elsewhere, mut off) = (0, 0, 0);
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
        let on = 100.0 * median_distance_to(&mesh, &placed, case as u64) / diag;
        let pose = if angle <= 2.0 && med <= 1.0 {
            right += 1;
            "right"
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
    }
    println!();
    println!(
        "{} cases, {} without a transform",
        rot.len() + missing,
        missing
    );
    println!(
        "right pose {right}, on the shape elsewhere {elsewhere}, off the shape {off}, none {missing}"
    );
    println!("measure | median | 90th percentile | 95th percentile");
    for (name, v) in [
        ("rotation °", &mut rot),
        ("scale %", &mut scale),
        ("displacement % of diagonal", &mut disp),
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
