//! What the examples share: a small collection generated in code, so that each example runs
//! without files (the shapes of `keycomp demo`, from `keycomp_shapes`).

use std::path::{Path, PathBuf};

use keycomp_shapes::{Class, GenerateParams};

/// Writes `per_class` generated shapes of each of four classes as OFF files in `dir`
/// (`dir/bird-00.off`, …) and returns their paths. 5,000 vertices each: a few seconds to
/// analyse in a release build.
pub fn generated_collection(
    dir: &Path,
    per_class: usize,
) -> Result<Vec<PathBuf>, Box<dyn std::error::Error>> {
    let params = GenerateParams {
        target_vertices: 5_000,
        ..GenerateParams::default()
    };
    let classes = &Class::ALL[..4];
    let shapes = keycomp_shapes::collection(classes, per_class, &params, &|_| {})?;
    let mut paths = Vec::new();
    for s in shapes {
        let path = dir.join(format!("{}.off", s.name));
        keycomp_mesh::write_off(&s.mesh, &path)?;
        paths.push(path);
    }
    Ok(paths)
}
