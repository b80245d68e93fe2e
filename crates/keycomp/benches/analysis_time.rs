//! Wall time of detection and of description per mesh, median of `--runs` (default 3).
//!
//! `cargo bench -p keycomp --bench analysis_time -- [--runs N] [--layout-reach R|none]
//! [--describe-vertices N] MESH...`
//! (MESH paths relative to the workspace root; when `cargo bench` did not run it, it prints its
//! usage and measures nothing)
//!
//! Prints one line per mesh: vertices, parts, detection ms, description ms, and their ratio.

use keycomp::analysis::Profile;
use keycomp_components::{DetectParams, detect};
use keycomp_describe::describe_with;
use keycomp_test_support::{bench_args, median, workspace_path};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(mut args) = bench_args(
        "cargo bench -p keycomp --bench analysis_time -- [--runs N] [--layout-reach R|none] [--describe-vertices N] MESH...",
    ) else {
        return Ok(());
    };
    args.remove(0); // the program
    let mut runs = 3;
    if let Some(i) = args.iter().position(|a| a == "--runs") {
        runs = args.get(i + 1).ok_or("--runs needs a number")?.parse()?;
        args.drain(i..i + 2);
    }
    let mut profile = Profile::current(&DetectParams::default());
    if let Some(i) = args.iter().position(|a| a == "--layout-reach") {
        let r = args
            .get(i + 1)
            .ok_or("--layout-reach needs a length or 'none'")?;
        profile.describe.layout_reach = if r == "none" { None } else { Some(r.parse()?) };
        args.drain(i..i + 2);
    }
    if let Some(i) = args.iter().position(|a| a == "--describe-vertices") {
        let n = args
            .get(i + 1)
            .ok_or("--describe-vertices needs a number")?;
        profile.describe.proxy_vertices = n.parse()?;
        args.drain(i..i + 2);
    }
    println!("mesh | vertices | parts | detect ms | describe ms | describe / detect");
    for path in &args {
        // `cargo bench` runs in crates/keycomp
        let mesh = keycomp_mesh::read_mesh(&workspace_path(path))?.mesh;
        let (mut td, mut tp, mut parts) = (Vec::new(), Vec::new(), 0);
        for _ in 0..runs {
            let t = Instant::now();
            let det = detect(&mesh, &profile.detect)?;
            td.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            let desc = describe_with(&mesh, &det, &profile.describe)?;
            tp.push(t.elapsed().as_secs_f64() * 1e3);
            parts = desc.components.len();
        }
        let (d, p) = (median(td), median(tp));
        println!(
            "{path} | {} | {parts} | {d:.0} | {p:.0} | {:.2}",
            mesh.num_vertices(),
            p / d
        );
    }
    Ok(())
}
