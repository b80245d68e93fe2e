//! A pure-Rust software renderer for triangle meshes with per-vertex colours: shaded pictures
//! of key-components, response fields and retrieval results, written as PNG. No GPU, no system
//! libraries; the same input gives the same bytes on any number of threads.
//!
//! # Steps
//! 1. **Camera.** An orthographic view from an azimuth and elevation about the up axis
//!    ([`RenderParams`]), fitted to the mesh's bounding sphere (centre of the bounding box,
//!    radius to the farthest used vertex) so the whole shape is visible and centred at the same
//!    scale from every direction.
//! 2. **Projection.** Every vertex is mapped to a grid of `(size · s)²` samples (`s` the
//!    supersampling factor) and snapped to 1/256 of a sample; each face gets its depth plane
//!    `z = c + a·x + b·y`.
//! 3. **Visibility.** Triangles are binned into bands of sample rows and rasterised band by
//!    band in parallel into a visibility buffer (nearest depth and face id per sample; Burns &
//!    Hunt 2013) with integer edge functions (Pineda 1988) and the top-left fill rule, so
//!    triangles sharing an edge leave neither cracks nor double coverage. Depth ties go to the
//!    smaller face id, making the result independent of drawing order.
//! 4. **Shading.** Each covered sample interpolates the vertex colours barycentrically and,
//!    for smooth shading, the area-weighted vertex normals (renormalised; flat shading uses
//!    the face normal). Lighting is two-sided Lambert: `ambient + headlight·max(0, n·v) +
//!    key·max(0, n·l)` times the colour, with `v` towards the viewer and `l` a key light from the
//!    upper left, normals of faces seen from behind turned to the viewer.
//! 5. **Outline** (optional). A covered sample is drawn in the outline colour when a
//!    neighbouring sample within the line width is background, lies behind the sample's face
//!    plane by more than a depth gap (silhouette), or belongs to a face whose normal differs by
//!    more than the crease angle.
//! 6. **Resolve.** Each pixel averages its `s²` samples over the background (straight alpha,
//!    so a transparent background gives anti-aliased alpha edges).
//!
//! # Complexity
//! `O(V + F + S·c)` time for `V` vertices, `F` faces and `S = (size·s)²` samples, where `c` is
//! the mean depth complexity (triangles covering a sample, about 2 for a closed surface); the
//! rasteriser also scans each triangle's bounding box. Memory is `O(V + F + S)` (8 bytes per
//! sample). A 50,000-vertex, 100,000-face mesh at 512 px with 2×2 supersampling renders in
//! about 40 ms on two cores, PNG encoding adds about 1 ms (`benches/render_time.rs`).
//!
//! # References
//! - J. Pineda, "A parallel algorithm for polygon rasterization", SIGGRAPH 1988, Computer
//!   Graphics 22(4), pp. 17–20 (edge functions).
//! - C. A. Burns and W. A. Hunt, "The visibility buffer: a cache-friendly approach to deferred
//!   shading", Journal of Computer Graphics Techniques 2(2), 2013.
//!
//! # Example
//! ```
//! use keycomp_render::{RenderParams, render};
//! let mesh = keycomp_mesh::synth::icosphere(2, 1.0);
//! let colors = vec![[200, 120, 60]; mesh.num_vertices()];
//! let params = RenderParams { size: 64, ..RenderParams::default() };
//! let image = render(&mesh, &colors, &params)?;
//! assert_eq!(image.width(), 64);
//! let png = image.to_png_bytes()?;
//! assert!(png.starts_with(b"\x89PNG"));
//! # Ok::<(), keycomp_render::RenderError>(())
//! ```

mod camera;
mod error;
mod image;
mod params;
mod raster;
mod shade;

pub use error::RenderError;
pub use image::Image;
pub use params::{MAX_SIZE, MAX_SUPERSAMPLING, Outline, RenderParams, Shading, UpAxis};

use keycomp_mesh::{Mesh, Vector3};
use rayon::prelude::*;

use camera::Camera;
use raster::{Plane, SUB};
use shade::Scene;

/// Renders `mesh` with one sRGB colour per vertex into a `size × size` image.
///
/// Errors when `colors.len()` differs from the number of vertices, a parameter is out of
/// range ([`RenderParams::validate`]), a face refers to a missing vertex or a used vertex is not
/// finite. A mesh without faces gives an image of the background.
pub fn render(
    mesh: &Mesh,
    colors: &[[u8; 3]],
    params: &RenderParams,
) -> Result<Image, RenderError> {
    params.validate()?;
    let n = mesh.positions.len();
    if colors.len() != n {
        return Err(RenderError::ColorCount {
            colors: colors.len(),
            vertices: n,
        });
    }
    for (face, f) in mesh.faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&v| v as usize >= n) {
            return Err(RenderError::FaceIndex {
                face,
                index,
                vertices: n,
            });
        }
    }
    let samples = params.size * params.supersampling;
    let camera = Camera::fit(mesh, params, samples)?;

    // Project and snap the vertices to the sub-sample grid.
    let projected: Vec<[f64; 3]> = mesh
        .positions
        .par_iter()
        .map(|p| camera.project(p))
        .collect();
    let fixed: Vec<[i64; 2]> = projected
        .iter()
        .map(|p| {
            [
                (p[0] * SUB as f64).round() as i64,
                (p[1] * SUB as f64).round() as i64,
            ]
        })
        .collect();
    let screen: Vec<[f64; 2]> = fixed
        .iter()
        .map(|q| [q[0] as f64 / SUB as f64, q[1] as f64 / SUB as f64])
        .collect();

    // Per-face depth planes and normals.
    let planes: Vec<Option<Plane>> = mesh
        .faces
        .par_iter()
        .map(|f| {
            Plane::through(f.map(|v| {
                let (s, p) = (screen[v as usize], projected[v as usize]);
                [s[0], s[1], p[2]]
            }))
        })
        .collect();
    let world_normals: Vec<Vector3<f64>> = (0..mesh.faces.len())
        .into_par_iter()
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            (b - a).cross(&(c - a))
        })
        .collect();
    let (face_normal, front): (Vec<[f32; 3]>, Vec<bool>) = world_normals
        .par_iter()
        .map(|n| {
            let v = camera.view_direction(&n.normalize());
            let v = if v.iter().all(|c| c.is_finite()) {
                v
            } else {
                [0.0, 0.0, 1.0]
            };
            if v[2] >= 0.0 {
                (v, true)
            } else {
                (v.map(|c| -c), false)
            }
        })
        .unzip();
    let vertex_normal = (params.shading == Shading::Smooth).then(|| {
        let mut acc = vec![Vector3::zeros(); n];
        for (f, nrm) in mesh.faces.iter().zip(&world_normals) {
            for &v in f {
                acc[v as usize] += nrm;
            }
        }
        acc.par_iter()
            .map(|a| {
                let len = a.norm();
                if len > 0.0 && len.is_finite() {
                    camera.view_direction(&(a / len))
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    });

    let vis = raster::rasterize(samples as usize, &fixed, &mesh.faces, &planes);
    let scene = Scene {
        faces: &mesh.faces,
        screen,
        colors,
        face_normal,
        front,
        vertex_normal,
        planes,
    };
    let gap = params
        .outline
        .map_or(0.0, |o| o.depth_gap * 2.0 * camera.radius * camera.scale);
    Ok(shade::resolve(&vis, &scene, params, gap))
}
