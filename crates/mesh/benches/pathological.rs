//! Writes meshes of pathological valence into a folder, for `keycomp bench detect`:
//! `bicone-5000.off` (a closed double cone whose two apices have valence 5,000) and
//! `polygon-N.off` for N = 20,000, 40,000 and 80,000 (one wavy polygon of N corners as a single
//! OFF face, which the reader fan-triangulates: its first corner gets valence N − 1).
//!
//! `cargo bench -p keycomp-mesh --bench pathological -- DIR` (DIR relative to the workspace
//! root; the `--bench` flag that `cargo bench` passes is ignored; without DIR it prints its
//! usage and writes nothing)

use std::fmt::Write as _;

use keycomp_test_support::workspace_path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` adds `--bench`
    let Some(dir) = std::env::args().skip(1).find(|a| a != "--bench") else {
        eprintln!("usage: cargo bench -p keycomp-mesh --bench pathological -- DIR");
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
