//! `keycomp render MESH -o OUT.png`: a shaded picture of a mesh, optionally with its
//! key-components, its Harris response or its keypoints coloured.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use keycomp_components::detect;
use keycomp_harris::HarrisParams;
use keycomp_mesh::{Topology, read_mesh};
use keycomp_render::{RenderParams, UpAxis, render};

use crate::args::DetectArgs;
use crate::colors::component_colors;
use crate::{colors, output};

pub const EXAMPLES: &str = "Examples:
  keycomp render cat0.off -o cat0.png --components
  keycomp render nefertiti.obj -o nefertiti.png --response --up z --size 1024
  keycomp render horse.ply -o horse.png --keypoints --view 120,15";

/// Arguments of `keycomp render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mesh file.
    pub mesh: PathBuf,
    /// Output PNG file.
    #[arg(short = 'o', long = "out", value_name = "OUT.png")]
    pub out: PathBuf,
    /// Colour each key-component (detection with the options below).
    #[arg(long, group = "mode")]
    pub components: bool,
    /// Colour the Harris 3D response by rank (dark blue low, yellow high).
    #[arg(long, group = "mode")]
    pub response: bool,
    /// Mark the Harris 3D keypoints and their 1-ring in magenta.
    #[arg(long, group = "mode")]
    pub keypoints: bool,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 512, value_name = "PX")]
    pub size: u32,
    /// View direction: azimuth and elevation in degrees.
    #[arg(long, value_name = "AZ,EL", value_delimiter = ',', default_values_t = [30.0, 20.0], allow_hyphen_values = true)]
    pub view: Vec<f64>,
    /// Which axis points up in the file: y (most scans and OBJ files) or z (CAD, some scans).
    #[arg(long, default_value = "y", value_parser = ["y", "z"])]
    pub up: String,
    /// Where key-components, responses and keypoints are computed: on the canonical surface
    /// (the default, as every command analyses a file; the colours are carried to the file's
    /// vertices by nearest surface vertex) or on the mesh as read.
    #[arg(long, value_name = "MODE", value_parser = ["canonical", "as-read"])]
    pub surface: Option<String>,
    #[command(flatten)]
    pub detect: DetectArgs,
}

pub fn run(args: Args) -> Result<ExitCode> {
    if !args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!("{}: the output must be a .png file", args.out.display());
    }
    let [azimuth, elevation] = args.view[..] else {
        bail!("--view takes two numbers, azimuth and elevation in degrees: e.g. --view 30,20");
    };
    let input = read_mesh(&args.mesh)?.mesh;
    let mut params = args.detect.params();
    let mut harris = args.detect.harris.params(HarrisParams::default());
    let coloured = args.components || args.response || args.keypoints;
    let canonical = coloured
        && crate::args::canonical_choice(args.surface.as_deref())
            .unwrap_or_else(|| args.detect.canonical_by_default());
    let surface = if canonical {
        // as in the analysis: no keypoints from fits that reach a border
        params.harris.skip_boundary = true;
        harris.skip_boundary = true;
        Some(
            keycomp::analysis::canonical_surface(
                &keycomp_mesh::Geometry::Mesh(input.clone()),
                &keycomp_surface::SurfaceParams::default(),
            )
            .with_context(|| format!("{}: no canonical surface", args.mesh.display()))?
            .mesh,
        )
    } else {
        None
    };
    let mesh = surface.as_ref().unwrap_or(&input);
    let cols = if args.components {
        let det = detect(mesh, &params)
            .with_context(|| format!("{}: key-component detection failed", args.mesh.display()))?;
        component_colors(mesh, &det)
    } else if args.response || args.keypoints {
        let topo = Topology::new(mesh);
        let h = keycomp_harris::detect(mesh, &topo, &harris)
            .with_context(|| format!("{}: Harris 3D failed", args.mesh.display()))?;
        if args.response {
            colors::by_rank(&h.response)
        } else {
            let mut c = vec![colors::GREY; mesh.num_vertices()];
            colors::highlight(&mut c, &topo, &h.keypoints);
            c
        }
    } else {
        vec![colors::GREY; mesh.num_vertices()]
    };
    // the picture is of the file: a canonical surface's colours go to its nearest vertices
    let cols = match &surface {
        Some(s) => {
            let nearest = keycomp_surface::nearest_vertices(&input.positions, &s.positions)
                .unwrap_or_else(|| vec![u32::MAX; input.num_vertices()]);
            nearest
                .iter()
                .map(|&v| cols.get(v as usize).copied().unwrap_or(colors::GREY))
                .collect()
        }
        None => cols,
    };
    let mesh = &input;
    let rp = RenderParams {
        size: args.size,
        azimuth_deg: azimuth,
        elevation_deg: elevation,
        up: if args.up == "z" { UpAxis::Z } else { UpAxis::Y },
        ..RenderParams::default()
    };
    let image = render(mesh, &cols, &rp)
        .with_context(|| format!("{}: rendering failed", args.mesh.display()))?;
    image
        .write_png(&args.out)
        .with_context(|| format!("{}: cannot write the image", args.out.display()))?;
    output::print_text(&format!(
        "wrote {} ({}×{} px)\n",
        args.out.display(),
        image.width(),
        image.height()
    ))?;
    Ok(ExitCode::SUCCESS)
}
