//! Index a folder of meshes, then list what the index holds.
//!
//! ```text
//! cargo run --release -p keycomp --example index_folder -- FOLDER INDEX
//! cargo run --release -p keycomp --example index_folder        # a generated collection
//! ```
//!
//! [`keycomp::collection::add`] reads every mesh, scan and point cloud under the folder,
//! detects its key-components, describes its parts and stores them in the index at `INDEX`
//! (created if missing; files already indexed with the same content are skipped). This is what
//! `keycomp index add INDEX FOLDER` does.

mod common;

use std::path::PathBuf;

use keycomp::collection::{self, AddOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let work = tempfile::tempdir()?;
    let (folder, index) = match args.as_slice() {
        [folder, index] => (folder.clone(), index.clone()),
        [] => {
            let folder = work.path().join("shapes");
            std::fs::create_dir(&folder)?;
            common::generated_collection(&folder, 2)?;
            (folder, work.path().join("index"))
        }
        _ => return Err("usage: index_folder [FOLDER INDEX]".into()),
    };
    // `&()`: no progress display; a command line passes its progress bar here
    let summary = collection::add(&index, &[folder], &AddOptions::default(), &())?;
    println!(
        "{} added, {} replaced, {} unchanged; {} shapes in {}",
        summary.added,
        summary.replaced,
        summary.unchanged,
        summary.shapes,
        index.display()
    );
    let reader = keycomp::collection::Reader::open(&index)?;
    for shape in reader.shapes()? {
        println!(
            "{:>3} parts, {:>6} vertices  {}",
            shape.record.components.len(),
            shape.record.vertex_count,
            shape.record.path.display()
        );
    }
    Ok(())
}
