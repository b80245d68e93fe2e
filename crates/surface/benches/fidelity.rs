//! How faithful the canonical surface is to its input: two-sided distances and the area ratio.
//!
//! `cargo bench -p keycomp-surface --bench fidelity -- [--vertices N] [--samples N] [--comb] PATH...`
//! (PATHs, files or folders searched for meshes, relative to the workspace root; when `cargo
//! bench` did not run it, it prints its usage and measures nothing)
//!
//! For every mesh: its canonical surface (`keycomp_surface::canonical`, the default parameters
//! or `--vertices N`), `--samples` points (default 20,000) drawn uniformly by area on each side,
//! and each one's distance to the other side's surface (the nearest point of the faces of its 8
//! nearest points among 200,000 drawn on that side), relative to the input's bounding-box
//! diagonal:
//! - *surface → input*: surface the input does not have (a web across a gap, a bridge over a
//!   crack) is far from the input;
//! - *input → surface*: input the surface lost (a thin part, or a soup's faces hidden inside
//!   the solid, which the surface drops on purpose).
//!
//! Prints one line per mesh (median, 99th percentile and largest distance each way, area of
//! the surface over the input's) and, per folder, the median of each column over its meshes
//! and the worst mesh of the 99th percentile surface → input. Deterministic (seeded samples).
//! `--comb` measures a generated comb's gaps first ([`comb`]).

use std::path::{Path, PathBuf};

use keycomp_mesh::sample::AreaSampler;
use keycomp_mesh::{Mesh, Point3, geometry, read_mesh};
use keycomp_surface::trim::closest_on_triangle;
use keycomp_surface::{Input, SurfaceParams, canonical};
use keycomp_test_support::{bench_args, median, quantile, take_number, workspace_path};
use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Points of the dense sampling distances are measured to.
const DENSE: usize = 200_000;

/// `n` points drawn uniformly by area on `mesh`, each with its face.
fn samples(mesh: &Mesh, n: usize, seed: u64) -> Vec<(Point3<f64>, usize)> {
    let Some(sampler) = AreaSampler::new(mesh) else {
        return Vec::new();
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| sampler.sample(&mut rng)).collect()
}

/// Faces whose nearest point is looked for: those of this many samples nearest a point.
const CANDIDATES: usize = 8;

/// Distances from each of `from` to `to`'s surface, sorted: the nearest point of the faces
/// of the [`CANDIDATES`] samples of the dense sampling `dense` of `to` nearest it.
fn distances(from: &[(Point3<f64>, usize)], to: &Mesh, dense: &[(Point3<f64>, usize)]) -> Vec<f64> {
    let coords: Vec<[f64; 3]> = dense.iter().map(|(p, _)| [p.x, p.y, p.z]).collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    let k = std::num::NonZero::new(CANDIDATES).expect("positive");
    let mut d: Vec<f64> = from
        .iter()
        .map(|(p, _)| {
            tree.nearest_n::<SquaredEuclidean>(&[p.x, p.y, p.z], k)
                .iter()
                .map(|nb| {
                    let f = dense[nb.item as usize].1;
                    (closest_on_triangle(p, &to.triangle(f)) - p).norm()
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    d.sort_by(f64::total_cmp);
    d
}

/// One mesh's row: median, p99 and max each way (relative to the diagonal), area ratio.
struct Row {
    name: String,
    cols: [f64; 7],
}

fn measure(path: &Path, params: &SurfaceParams, n: usize) -> Result<Row, String> {
    let mesh = read_mesh(path).map_err(|e| e.to_string())?.mesh;
    let surface = canonical(Input::Mesh(&mesh), params)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .mesh;
    let diag = geometry::bounding_box(&mesh).diagonal();
    let to_input = distances(&samples(&surface, n, 1), &mesh, &samples(&mesh, DENSE, 2));
    let to_surface = distances(
        &samples(&mesh, n, 3),
        &surface,
        &samples(&surface, DENSE, 4),
    );
    let rel = |x: f64| 100.0 * x / diag;
    Ok(Row {
        name: path.display().to_string(),
        cols: [
            rel(quantile(&to_input, 0.5)),
            rel(quantile(&to_input, 0.99)),
            rel(quantile(&to_input, 1.0)),
            rel(quantile(&to_surface, 0.5)),
            rel(quantile(&to_surface, 0.99)),
            rel(quantile(&to_surface, 1.0)),
            geometry::total_area(&surface) / geometry::total_area(&mesh),
        ],
    })
}

fn meshes_in(path: &Path) -> Vec<PathBuf> {
    if !path.is_dir() {
        return vec![path.to_path_buf()];
    }
    let mut out: Vec<PathBuf> = std::fs::read_dir(path)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    out.retain(|p| {
        keycomp_mesh::Format::from_path(p).is_ok()
            && read_mesh(p).is_ok_and(|m| m.mesh.num_faces() > 0)
    });
    out.sort();
    out
}

fn print(row: &Row) {
    let c = row.cols;
    println!(
        "{} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3}",
        row.name, c[0], c[1], c[2], c[3], c[4], c[5], c[6]
    );
}

/// The generated comb: a base and six teeth (boxes of twelve triangles touching as a soup,
/// teeth 0.2 wide and 1 long) with gaps of 0.5, 1.5, 2, 3 and 5 grid spacings between them at
/// 12,000 vertices, and for each gap the faces of the canonical surface in the air across it
/// (centroid inside the gap, along the teeth, farther than half a spacing from the comb): webs.
fn comb() -> Result<(), Box<dyn std::error::Error>> {
    let cube = keycomp_mesh::synth::cuboid;
    let gaps = [0.015, 0.045, 0.06, 0.09, 0.15];
    let width = 0.2 * (gaps.len() + 1) as f64 + gaps.iter().sum::<f64>();
    let mut soup = cube([0.0; 3], [width, 0.3, 0.2]);
    let (mut x, mut slabs) = (0.0, Vec::new());
    for i in 0..=gaps.len() {
        let tooth = cube([x, 0.3, 0.0], [0.2, 1.0, 0.2]);
        let n = soup.positions.len() as u32;
        soup.positions.extend(tooth.positions);
        soup.faces
            .extend(tooth.faces.iter().map(|t| t.map(|v| v + n)));
        x += 0.2;
        if let Some(g) = gaps.get(i) {
            slabs.push((x, x + g));
            x += g;
        }
    }
    let params = SurfaceParams {
        vertices: 12_000,
        ..SurfaceParams::default()
    };
    let s = canonical(Input::Mesh(&soup), &params)?;
    let h = s.spacing;
    println!("comb: spacing {h:.4}, offset {:.4}", s.offset);
    println!("gap (spacings) | faces in the air across it");
    for (a, b) in slabs {
        let inside = s
            .mesh
            .faces
            .iter()
            .map(|t| {
                Point3::from(
                    t.iter()
                        .map(|&v| s.mesh.positions[v as usize].coords)
                        .sum::<keycomp_mesh::Vector3<f64>>()
                        / 3.0,
                )
            })
            .filter(|c| {
                c.x > a + 0.5 * h
                    && c.x < b - 0.5 * h
                    && c.y > 0.3 + 2.0 * h
                    && (0..soup.num_faces())
                        .map(|f| (closest_on_triangle(c, &soup.triangle(f)) - c).norm())
                        .fold(f64::INFINITY, f64::min)
                        > 0.5 * h
            })
            .count();
        println!("{:.2} | {inside}", (b - a) / h);
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "cargo bench -p keycomp-surface --bench fidelity -- [--vertices N] [--samples N] [--comb] PATH...";
    let Some(mut args) = bench_args(usage) else {
        return Ok(());
    };
    args.remove(0);
    let mut params = SurfaceParams::default();
    let mut n = 20_000;
    if let Some(v) = take_number(&mut args, "--vertices")? {
        params.vertices = v;
    }
    if let Some(v) = take_number(&mut args, "--samples")? {
        n = v;
    }
    if let Some(i) = args.iter().position(|a| a == "--comb") {
        args.remove(i);
        comb()?;
        if args.is_empty() {
            return Ok(());
        }
    }
    if args.is_empty() {
        return Err(usage.into());
    }
    println!(
        "distances in % of the input's bounding-box diagonal; vertices {}",
        params.vertices
    );
    println!(
        "mesh | surface→input median | p99 | max | input→surface median | p99 | max | area ratio"
    );
    let mut summaries = Vec::new();
    for arg in &args {
        let rows: Vec<Row> = meshes_in(&workspace_path(arg))
            .iter()
            .filter_map(|p| match measure(p, &params, n) {
                Ok(r) => Some(r),
                Err(e) => {
                    eprintln!("skipped: {e}");
                    None
                }
            })
            .collect();
        rows.iter().for_each(print);
        if rows.len() > 1 {
            let cols: Vec<f64> = (0..7)
                .map(|k| median(rows.iter().map(|r| r.cols[k]).collect()))
                .collect();
            let worst = rows
                .iter()
                .max_by(|a, b| a.cols[1].total_cmp(&b.cols[1]))
                .map(|r| format!("{} ({:.3})", r.name, r.cols[1]))
                .unwrap_or_default();
            summaries.push((arg.clone(), rows.len(), cols, worst));
        }
    }
    if !summaries.is_empty() {
        println!();
        println!(
            "folder | meshes | surface→input median | p99 | max | input→surface median | p99 | max | area ratio | worst p99 surface→input"
        );
        for (arg, count, c, worst) in summaries {
            println!(
                "{arg} | {count} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {worst}",
                c[0], c[1], c[2], c[3], c[4], c[5], c[6]
            );
        }
    }
    Ok(())
}
