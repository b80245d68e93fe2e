//! `keycomp match A B`: part-to-part matching of two meshes by their key-components.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Result;
use keycomp_components::Detection;
use keycomp_mesh::{Mesh, read_mesh};
use keycomp_retrieval::MatchParams;
use serde::Serialize;

pub use keycomp::{Analysed, analyse};

use crate::detect::DetectArgs;
use crate::index_cmd::{Profile, UnitsArgs};
use crate::{colors, output};

pub const EXAMPLES: &str = "Examples:
  keycomp match cat0.off cat3.off
  keycomp match scan.ply model.off --json
  keycomp match a.off b.off --ply-a a-matched.ply --ply-b b-matched.ply";

/// Arguments of `keycomp match`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// First mesh (the query side: the score is relative to its components).
    pub a: PathBuf,
    /// Second mesh.
    pub b: PathBuf,
    #[command(flatten)]
    pub detect: DetectArgs,
    #[command(flatten)]
    pub units: UnitsArgs,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write A with each matched component in its pair's colour (PLY).
    #[arg(long, value_name = "OUT")]
    pub ply_a: Option<PathBuf>,
    /// Write B with each matched component in its pair's colour (PLY).
    #[arg(long, value_name = "OUT")]
    pub ply_b: Option<PathBuf>,
}

#[derive(Serialize)]
struct MatchJson {
    a_component: usize,
    b_component: usize,
    distance: f32,
}

#[derive(Serialize)]
struct Report {
    a: String,
    b: String,
    components_a: usize,
    components_b: usize,
    score: f64,
    scale: Option<f64>,
    rejected: usize,
    matches: Vec<MatchJson>,
    timings_ms: Timings,
}

#[derive(Serialize)]
struct Timings {
    a: f64,
    b: f64,
    matching: f64,
}

/// Vertex colours of one side of a match: the detection's key-components dark grey, matched
/// parts (indices into `desc`) in their pair's colour, larger parts first so that smaller ones
/// stay visible on top.
fn pair_colors(
    mesh: &Mesh,
    det: &Detection,
    desc: &keycomp_describe::ShapeDescription,
    pairs: &[(usize, usize)],
) -> Vec<[u8; 3]> {
    let mut cols = vec![colors::GREY; mesh.num_vertices()];
    for c in &det.components {
        for &v in &c.vertices {
            cols[v as usize] = [110, 110, 110]; // unmatched components: dark grey
        }
    }
    let mut order: Vec<&(usize, usize)> = pairs
        .iter()
        .filter(|(_, c)| *c < desc.components.len())
        .collect();
    order.sort_by(|a, b| {
        desc.components[b.1]
            .area
            .total_cmp(&desc.components[a.1].area)
    });
    for &&(k, comp) in &order {
        let col = colors::distinct(k);
        for &v in &desc.components[comp].vertices {
            if let Some(c) = cols.get_mut(v as usize) {
                *c = col;
            }
        }
    }
    cols
}

pub fn run(args: Args) -> Result<ExitCode> {
    let describe = args.units.describe_params(|| {
        read_mesh(&args.b)
            .map(|m| vec![keycomp_mesh::geometry::total_area(&m.mesh)])
            .unwrap_or_default()
    })?;
    let params = Profile::with(&args.detect.retrieval_params(), describe);
    let (a, b) = rayon::join(|| analyse(&args.a, &params), || analyse(&args.b, &params));
    let (a, b) = (a?, b?);
    let t = Instant::now();
    let m = a.match_with(&b, &MatchParams::default());
    let match_ms = t.elapsed().as_secs_f64() * 1e3;
    if let Some(out) = &args.ply_a {
        let pairs: Vec<(usize, usize)> = m
            .matches
            .iter()
            .enumerate()
            .map(|(k, x)| (k, x.query))
            .collect();
        keycomp_mesh::write_ply_colored(
            &a.mesh,
            &pair_colors(&a.mesh, &a.detection, &a.description, &pairs),
            out,
        )?;
    }
    if let Some(out) = &args.ply_b {
        let pairs: Vec<(usize, usize)> = m
            .matches
            .iter()
            .enumerate()
            .map(|(k, x)| (k, x.target))
            .collect();
        keycomp_mesh::write_ply_colored(
            &b.mesh,
            &pair_colors(&b.mesh, &b.detection, &b.description, &pairs),
            out,
        )?;
    }
    if args.json {
        output::print_json(&Report {
            a: args.a.display().to_string(),
            b: args.b.display().to_string(),
            components_a: a.description.components.len(),
            components_b: b.description.components.len(),
            score: m.score,
            scale: m.scale,
            rejected: m.rejected,
            matches: m
                .matches
                .iter()
                .map(|x| MatchJson {
                    a_component: x.query,
                    b_component: x.target,
                    distance: x.distance,
                })
                .collect(),
            timings_ms: Timings {
                a: a.ms,
                b: b.ms,
                matching: match_ms,
            },
        })?;
    } else {
        let mut s = String::new();
        writeln!(
            s,
            "{}: {} parts; {}: {} parts",
            args.a.display(),
            a.description.components.len(),
            args.b.display(),
            b.description.components.len()
        )?;
        writeln!(
            s,
            "score {:.3} ({} matched pairs, {} rejected by the layout check{})",
            m.score,
            m.matches.len(),
            m.rejected,
            m.scale
                .map(|x| format!(", length ratio B/A {x:.3}"))
                .unwrap_or_default()
        )?;
        if !m.matches.is_empty() {
            writeln!(
                s,
                "{:>4}  {:>11}  {:>11}  {:>9}",
                "pair", "A part", "B part", "distance"
            )?;
        }
        for (k, x) in m.matches.iter().enumerate() {
            writeln!(
                s,
                "{:>4}  {:>11}  {:>11}  {:>9.4}",
                k, x.query, x.target, x.distance
            )?;
        }
        writeln!(
            s,
            "time: A {:.0} ms, B {:.0} ms, matching {match_ms:.2} ms",
            a.ms, b.ms
        )?;
        output::print_text(&s)?;
    }
    Ok(ExitCode::SUCCESS)
}
