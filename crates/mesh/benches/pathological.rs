//! Writes meshes of pathological valence into a folder, for `keycomp bench detect`:
//! `bicone-5000.off` (a closed double cone whose two apices have valence 5,000) and
//! `polygon-N.off` for N = 20,000, 40,000 and 80,000 (one wavy polygon of N corners as a single
//! OFF face, which the reader fan-triangulates: its first corner gets valence N − 1).
//!
//! `cargo bench -p keycomp-mesh --bench pathological -- DIR` (DIR relative to the workspace
//! root; without DIR, or when `cargo bench` did not run it, it prints its usage and writes
//! nothing)

use std::fmt::Write as _;

use keycomp_test_support::{bench_args, workspace_path};

const USAGE: &str = "cargo bench -p keycomp-mesh --bench pathological -- DIR";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args(USAGE) else {
        return Ok(());
    };
    let Some(dir) = args.get(1) else {
        eprintln!("usage: {USAGE}");
        return Ok(());
    };
    // `cargo bench` runs in crates/mesh
    let dir = workspace_path(dir);
    std::fs::create_dir_all(&dir)?;
    keycomp_mesh::write_off(
        &keycomp_mesh::synth::bicone(5000),
        &dir.join("bicone-5000.off"),
    )?;
    for n in [20_000usize, 40_000, 80_000] {
        let mut text = format!("OFF\n{n} 1 0\n");
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let r = 1.0 + 0.1 * (7.0 * a).sin();
            writeln!(
                text,
                "{} {} {}",
                r * a.cos(),
                r * a.sin(),
                0.05 * (13.0 * a).sin()
            )?;
        }
        text.push_str(&n.to_string());
        for i in 0..n {
            write!(text, " {i}")?;
        }
        text.push('\n');
        std::fs::write(dir.join(format!("polygon-{n}.off")), text)?;
    }
    Ok(())
}
