//! Accuracy and speed of the keypoint distance matrix on a simplified proxy (pipeline step 3,
//! `GeodesicOptions`) against the full mesh, and against great circles on an icosphere.
//!
//! For each mesh file: unit-area normalisation and Harris keypoints (KC-1 defaults, 1 % of the
//! vertices) exactly as `detect` does, then the K×K matrix on the full mesh (every obtuse
//! corner split) and under each setting given. Printed per setting: proxy vertices, mean and
//! max relative difference over the pairs i < j, the largest absolute difference in units of
//! R = 0.15 (the KC-1 clustering radius on the unit-area mesh), milliseconds to simplify and
//! for the whole matrix (median of `--runs`, full mesh and settings alternated in each run).
//! With `--sphere L`: `icosphere(L)` scaled to unit area, K = 1 % random vertices (seed 5),
//! compared with great circles as well.
//!
//! ```text
//! cargo bench -p keycomp-components --bench geodesic_proxy -- \
//!     [--runs 3] [--settings 20000@90,0@110,10000@90/100:2#12500,...] [--sphere 6] MESH...
//! ```
//!
//! A setting is `N@ANGLE[/L[:F[l]]]`: proxy of at most N vertices (0 = full mesh), obtuse
//! corners split from ANGLE degrees, and optionally landmark fronts: L landmarks, short fronts
//! stopped at F covering radii (default 2), or with the suffix `l` at F times each keypoint's
//! own distance to its nearest landmark (`GeodesicOptions::local_landmark_radius`); a suffix
//! `#C` simplifies in cells of at least C vertices (`GeodesicOptions::proxy_cell_vertices`;
//! none: one cell). Threads: the global rayon pool
//! (`RAYON_NUM_THREADS=2` for the two-thread figures). MESH paths are relative to the
//! workspace root. When `cargo bench` did not run it, it prints its usage and measures nothing.

use std::time::Instant;

use keycomp_components::{GeodesicOptions, keypoint_distances};
use keycomp_harris::HarrisParams;
use keycomp_mesh::{Mesh, Topology, VertexId, geometry, read_mesh, synth};
use keycomp_test_support::{bench_args, median, workspace_path};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// (mean relative, max relative, max absolute) difference of `a` from `reference` over i < j.
fn compare(a: &[f64], reference: &[f64], k: usize) -> (f64, f64, f64) {
    let (mut sum, mut max, mut abs, mut n) = (0.0, 0.0f64, 0.0f64, 0usize);
    for i in 0..k {
        for j in i + 1..k {
            let (x, r) = (a[i * k + j], reference[i * k + j]);
            if r > 0.0 {
                let d = (x - r).abs();
                sum += d / r;
                max = max.max(d / r);
                abs = abs.max(d);
                n += 1;
            }
        }
    }
    (sum / n.max(1) as f64, max, abs)
}

fn parse_setting(s: &str) -> Res<GeodesicOptions> {
    let (s, cells) = s.split_once('#').unwrap_or((s, "0"));
    let (s, landmarks) = s.split_once('/').unwrap_or((s, "0"));
    let (landmarks, radius) = landmarks.split_once(':').unwrap_or((landmarks, "2"));
    let (radius, local) = match radius.strip_suffix('l') {
        Some(r) => (r, true),
        None => (radius, false),
    };
    let (n, a) = s.split_once('@').unwrap_or((s, "90"));
    Ok(GeodesicOptions {
        proxy_vertices: n.parse()?,
        min_split_angle_degrees: a.parse()?,
        landmarks: landmarks.parse()?,
        landmark_radius: radius.parse()?,
        local_landmark_radius: local,
        proxy_cell_vertices: cells.parse()?,
    })
}

fn label(o: &GeodesicOptions) -> String {
    let base = format!("{}@{}", o.proxy_vertices, o.min_split_angle_degrees);
    let base = if o.landmarks > 0 {
        format!(
            "{base}/{}:{}{}",
            o.landmarks,
            o.landmark_radius,
            if o.local_landmark_radius { "l" } else { "" }
        )
    } else {
        base
    };
    if o.proxy_cell_vertices > 0 {
        format!("{base}#{}", o.proxy_cell_vertices)
    } else {
        base
    }
}

fn run(
    name: &str,
    mesh: &Mesh,
    keypoints: &[VertexId],
    exact: Option<&[f64]>,
    settings: &[GeodesicOptions],
    runs: usize,
) -> Res<()> {
    let topo = Topology::new(mesh);
    let k = keypoints.len();
    let full = GeodesicOptions::full_mesh();
    let all: Vec<GeodesicOptions> = std::iter::once(full)
        .chain(settings.iter().copied())
        .collect();
    let mut times = vec![(Vec::new(), Vec::new()); all.len()];
    let mut results = vec![(Vec::new(), 0usize); all.len()];
    for _ in 0..runs {
        for (i, o) in all.iter().enumerate() {
            let t = Instant::now();
            let (m, nv, simp) = keypoint_distances(mesh, &topo, keypoints, o)?;
            times[i].0.push(t.elapsed().as_secs_f64() * 1e3);
            times[i].1.push(simp);
            results[i] = (m.into_vec(), nv);
        }
    }
    println!(
        "{name}: {} vertices, K = {k}{}",
        mesh.num_vertices(),
        if exact.is_some() {
            ", vs great circles"
        } else {
            ""
        }
    );
    println!(
        "| setting | proxy vertices | mean rel. diff % | max rel. diff % | max abs. diff / R | \
         simplify ms | matrix ms | matrix vs full |{}",
        if exact.is_some() {
            " mean rel. error vs great circles % | max % |"
        } else {
            ""
        }
    );
    let full_ms = median(times[0].0.clone());
    for (i, o) in all.iter().enumerate() {
        let (mean, max, abs) = compare(&results[i].0, &results[0].0, k);
        let ms = median(times[i].0.clone());
        let mut line = format!(
            "| {} | {} | {:.3} | {:.2} | {:.3} | {:.0} | {:.0} | {:.2} |",
            label(o),
            results[i].1,
            100.0 * mean,
            100.0 * max,
            abs / 0.15,
            median(times[i].1.clone()),
            ms,
            ms / full_ms
        );
        if let Some(e) = exact {
            let (m, mx, _) = compare(&results[i].0, e, k);
            line.push_str(&format!(" {:.3} | {:.2} |", 100.0 * m, 100.0 * mx));
        }
        println!("{line}");
    }
    println!();
    Ok(())
}

fn main() -> Res<()> {
    let Some(args) = bench_args(
        "cargo bench -p keycomp-components --bench geodesic_proxy -- \
         [--runs 3] [--settings 20000@90,0@110,...] [--sphere 6] MESH...",
    ) else {
        return Ok(());
    };
    let mut args = args.into_iter().skip(1);
    let mut runs = 3;
    let mut settings = Vec::new();
    let mut sphere = None;
    let mut files = Vec::new();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--runs" => runs = args.next().ok_or("--runs N")?.parse()?,
            "--settings" => {
                for s in args.next().ok_or("--settings LIST")?.split(',') {
                    settings.push(parse_setting(s)?);
                }
            }
            "--sphere" => sphere = Some(args.next().ok_or("--sphere L")?.parse::<u32>()?),
            _ => files.push(a),
        }
    }
    if settings.is_empty() {
        for n in [10_000, 15_000, 20_000, 25_000, 30_000] {
            settings.push(GeodesicOptions {
                proxy_vertices: n,
                ..GeodesicOptions::full_mesh()
            });
        }
    }
    if let Some(level) = sphere {
        let (mesh, _) = geometry::normalize_unit_area(&synth::icosphere(level, 1.0));
        let n = mesh.num_vertices();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut kp: Vec<VertexId> = (0..n / 100)
            .map(|_| rng.random_range(0..n as VertexId))
            .collect();
        kp.sort_unstable();
        kp.dedup();
        // radius of the unit-area sphere: 4πr² = 1
        let r = (0.25 / std::f64::consts::PI).sqrt();
        let k = kp.len();
        let mut exact = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..k {
                let (p, q) = (
                    mesh.positions[kp[i] as usize].coords.normalize(),
                    mesh.positions[kp[j] as usize].coords.normalize(),
                );
                exact[i * k + j] = r * p.dot(&q).clamp(-1.0, 1.0).acos();
            }
        }
        run(
            &format!("icosphere({level})"),
            &mesh,
            &kp,
            Some(&exact),
            &settings,
            runs,
        )?;
    }
    for f in &files {
        // `cargo bench` runs in crates/components
        let mesh = read_mesh(&workspace_path(f))?.mesh;
        let (norm, _) = geometry::normalize_unit_area(&mesh);
        let topo = Topology::new(&norm);
        let harris = keycomp_harris::detect(&norm, &topo, &HarrisParams::default())?;
        run(f, &norm, &harris.keypoints, None, &settings, runs)?;
    }
    Ok(())
}
