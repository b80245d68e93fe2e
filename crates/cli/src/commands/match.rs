//! `keycomp match A B`: part-to-part matching of two meshes by their key-components.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use keycomp::matching::{MatchOptions, match_files};
use keycomp_components::Detection;
use keycomp_mesh::Mesh;

use crate::args::DetectArgs;
use crate::args::UnitsArgs;
use crate::{colors, output};

pub const EXAMPLES: &str = "Examples:
  keycomp match cat0.off cat3.off
  keycomp match scan.ply model.off --json
  keycomp match a.off b.off --ply-a a-matched.ply --ply-b b-matched.ply
  keycomp match bun000.ply bunny.ply --aligned bun000-on-bunny.ply";

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
    #[command(flatten)]
    pub surface: crate::args::SurfaceArgs,
    /// Weight of the pose check, 0–1: above 0, pairs of matched parts whose straight-line
    /// distances disagree (another pose) lower the score. 0 (default): no pose check.
    #[arg(long, value_name = "W", default_value_t = 0.0, value_parser = crate::args::unit_weight)]
    pub pose: f64,
    /// Weight of geometric verification, 0–1, or auto (the default: 0.5 for a query with a
    /// boundary, a fragment or a scan, 1 in file units or on canonical surfaces; 0 for a closed
    /// shape): each shape's
    /// score is scaled by 1 − W·(1 − f), f the share of the query's surface that lies on the
    /// shape once aligned by the matched parts, so a fragment's exact source ranks first.
    #[arg(long, value_name = "W|auto", default_value = "auto", value_parser = crate::args::auto_or_unit_weight)]
    pub verify: crate::args::AutoWeight,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write A with each matched component in its pair's colour (PLY).
    #[arg(long, value_name = "OUT")]
    pub ply_a: Option<PathBuf>,
    /// Write B with each matched component in its pair's colour (PLY).
    #[arg(long, value_name = "OUT")]
    pub ply_b: Option<PathBuf>,
    /// Write A moved onto B (the transform, `transform` in --json) to OUT: its mesh, or its
    /// points for a point cloud, as .off, .ply or .glb by OUT's extension. Exit 1 when no
    /// alignment is found (nothing written).
    #[arg(long, value_name = "OUT")]
    pub aligned: Option<PathBuf>,
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
    if let Some(out) = &args.aligned {
        // before any work: a name whose format is unknown is refused at once
        output::moved_format(out)?;
    }
    let options = MatchOptions {
        detect: args.detect.explicit(),
        units: args.units.units()?.unwrap_or_default(),
        canonical: args
            .surface
            .canonical()
            .unwrap_or_else(|| args.detect.canonical_by_default()),
        pose_weight: args.pose,
        verify_weight: args.verify.0,
    };
    let (a, b, m) = match_files(&args.a, &args.b, &options)?;
    for (path, analysed) in [(&args.a, &a), (&args.b, &b)] {
        for w in &analysed.warnings {
            eprintln!("warning: {}: {w}", path.display());
        }
    }
    let match_ms = m.timings_ms.matching;
    let mut aligned = true;
    if let Some(out) = &args.aligned {
        match &m.transform {
            Some(t) => output::write_moved(&a.input, t, out)?,
            None => {
                eprintln!(
                    "{}: no alignment of A on B was found; {} not written",
                    args.a.display(),
                    out.display()
                );
                aligned = false;
            }
        }
    }
    let sides = [
        (
            &args.ply_a,
            &args.a,
            &a,
            m.matches.iter().map(|x| x.a_component).collect::<Vec<_>>(),
        ),
        (
            &args.ply_b,
            &args.b,
            &b,
            m.matches.iter().map(|x| x.b_component).collect::<Vec<_>>(),
        ),
    ];
    for (out, path, analysed, components) in sides {
        let Some(out) = out else { continue };
        let pairs: Vec<(usize, usize)> = components.into_iter().enumerate().collect();
        let colours = pair_colors(
            &analysed.mesh,
            &analysed.detection,
            &analysed.description,
            &pairs,
        );
        // a canonical surface's colours go onto the file's own vertices
        let input = if analysed.canonical {
            Some(keycomp_mesh::read_input(path)?.geometry)
        } else {
            None
        };
        output::write_colours_on_input(input, &analysed.mesh, &colours, out)?;
    }
    if args.json {
        output::print_json(&m)?;
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
            "score {:.3} ({} matched pairs, {} rejected by the layout and size checks{}{}{})",
            m.score,
            m.matches.len(),
            m.rejected,
            m.scale
                .map(|x| format!(", length ratio B/A {x:.3}"))
                .unwrap_or_default(),
            m.pose
                .map(|x| format!(", pose agreement {x:.2}"))
                .unwrap_or_default(),
            m.verified
                .map(|x| format!(", {:.0} % of A on B once aligned", 100.0 * x))
                .unwrap_or_default()
        )?;
        if let Some(t) = &m.transform {
            let [x, y, z] = t.translation;
            writeln!(
                s,
                "A onto B: scale {:.4}, rotation {:.2}°, translation ({x:.4}, {y:.4}, {z:.4}){} (the 4×4 matrix in --json)",
                t.scale,
                t.angle_degrees(),
                t.rms
                    .map(|r| format!(", RMS {r:.3e} after refinement"))
                    .unwrap_or_default()
            )?;
        }
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
                k, x.a_component, x.b_component, x.distance
            )?;
        }
        writeln!(
            s,
            "time: A {:.0} ms, B {:.0} ms, matching {match_ms:.2} ms",
            a.ms, b.ms
        )?;
        output::print_text(&s)?;
    }
    Ok(if aligned {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
