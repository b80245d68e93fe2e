//! Rendering oracles: exact pixel areas, colour interpolation, depth order, no cracks, the
//! disc of a sphere, determinism, PNG round trip and view orientation.

use keycomp_mesh::{Mesh, Point3, synth};
use keycomp_render::{Image, Outline, RenderError, RenderParams, Shading, UpAxis, render};

const BLACK: [u8; 4] = [0, 0, 0, 255];

/// Unlit, outline-free parameters: a surface facing the camera keeps its vertex colour
/// exactly (ambient 1, no other light), the background is black.
fn plain(size: u32, ss: u32) -> RenderParams {
    RenderParams {
        size,
        azimuth_deg: 0.0,
        elevation_deg: 0.0,
        background: BLACK,
        ambient: 1.0,
        headlight: 0.0,
        key_light: 0.0,
        supersampling: ss,
        outline: None,
        shading: Shading::Flat,
        ..RenderParams::default()
    }
}

fn mesh(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> Mesh {
    Mesh {
        positions: positions
            .iter()
            .map(|p| Point3::new(p[0], p[1], p[2]))
            .collect(),
        faces: faces.to_vec(),
    }
}

/// Coverage of each pixel as a fraction, from a white-on-black render.
fn coverage(img: &Image) -> Vec<f64> {
    img.pixels()
        .iter()
        .map(|p| f64::from(p[0]) / 255.0)
        .collect()
}

/// Pixels per world unit for a mesh of bounding radius `r` (default margin 0.04).
fn scale(size: u32, r: f64) -> f64 {
    size as f64 / 2.0 * (1.0 - 2.0 * 0.04) / r
}

#[test]
fn triangle_covers_its_area() {
    // A right triangle in the z = 0 plane, facing the camera; a far-away tiny triangle fixes
    // the bounding sphere so the scale is known.
    let m = mesh(
        &[
            [-0.7, -0.6, 0.0],
            [0.5, -0.6, 0.0],
            [-0.7, 0.45, 0.0],
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [-1.0, 1e-3, 0.0],
        ],
        &[[0, 1, 2], [3, 4, 5]],
    );
    // The bounding box is x ∈ [−1, 1], y ∈ [−0.6, 0.45]: centre (0, −0.075), radius to the
    // farthest used vertex.
    let c = [0.0, -0.075];
    let r = m
        .positions
        .iter()
        .map(|p| ((p.x - c[0]).powi(2) + (p.y - c[1]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    for ss in [1, 2, 3] {
        let colors = vec![[255, 255, 255]; 6];
        let img = render(&m, &colors, &plain(400, ss)).expect("render");
        let covered: f64 = coverage(&img).iter().sum();
        let s = scale(400, r);
        let expected = 0.5 * 1.2 * 1.05 * s * s;
        // The sliver triangle adds at most a row of pixels.
        assert!(
            (covered - expected).abs() < 0.01 * expected,
            "ss {ss}: covered {covered}, expected {expected}"
        );
    }
}

#[test]
fn colours_interpolate_barycentrically() {
    let m = mesh(
        &[[-1.0, -0.8, 0.0], [1.0, -0.8, 0.0], [0.0, 1.0, 0.0]],
        &[[0, 1, 2]],
    );
    let colors = [[240, 0, 30], [0, 180, 60], [30, 90, 240]];
    let img = render(&m, &colors, &plain(101, 1)).expect("render");
    // The centroid of the triangle is at y = −0.2; its pixel must carry the average colour.
    // Bounding box centre (0, 0.1), radius = distance to a bottom corner.
    let r = (1.0f64 + 0.9 * 0.9).sqrt();
    let s = scale(101, r);
    let (cx, cy) = (50.5, 50.5 - s * (-0.2 - 0.1));
    let p = img.pixel(cx as u32, cy as u32).expect("inside");
    for k in 0..3 {
        let mean = (colors.iter().map(|c| f64::from(c[k])).sum::<f64>()) / 3.0;
        assert!(
            (f64::from(p[k]) - mean).abs() <= 4.0,
            "channel {k}: {} vs {mean}",
            p[k]
        );
    }
    // Near a corner the corner's colour dominates.
    let corner = img
        .pixel(50, (50.5 - s * (0.95 - 0.1)) as u32)
        .expect("inside");
    assert!(corner[2] > 200 && corner[0] < 60, "{corner:?}");
}

#[test]
fn nearer_triangle_wins_in_any_order() {
    // Two overlapping squares' triangles: red at z = 0.5 (nearer the camera at +z), blue at 0.
    let pos = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
        [-0.5, -0.5, 0.5],
        [0.5, -0.5, 0.5],
        [0.0, 0.5, 0.5],
    ];
    let colors = [
        [0, 0, 255],
        [0, 0, 255],
        [0, 0, 255],
        [255, 0, 0],
        [255, 0, 0],
        [255, 0, 0],
    ];
    let a = render(&mesh(&pos, &[[0, 1, 2], [3, 4, 5]]), &colors, &plain(64, 2)).expect("a");
    let b = render(&mesh(&pos, &[[3, 4, 5], [0, 1, 2]]), &colors, &plain(64, 2)).expect("b");
    assert_eq!(a, b);
    let centre = a.pixel(32, 32).expect("centre");
    assert_eq!(centre, [255, 0, 0, 255]);
    // From behind (azimuth 180), the blue triangle is nearer.
    let back = RenderParams {
        azimuth_deg: 180.0,
        ..plain(64, 2)
    };
    let c = render(&mesh(&pos, &[[0, 1, 2], [3, 4, 5]]), &colors, &back).expect("c");
    assert_eq!(c.pixel(32, 32).expect("centre"), [0, 0, 255, 255]);
}

#[test]
fn shared_edges_leave_no_cracks_or_double_coverage() {
    // A fan of thin triangles around a centre plus a square split along its diagonal, all in
    // one plane: every pixel inside is covered exactly once, so with additive-looking colours
    // any crack shows as background and any double coverage cannot be seen, so count samples.
    let mut pos = vec![[0.0, 0.0, 0.0]];
    // An even count keeps the polygon point-symmetric: bounding box centred, radius 1.
    let k = 36;
    for i in 0..k {
        let t = i as f64 / k as f64 * std::f64::consts::TAU + 0.123;
        pos.push([t.cos(), t.sin(), 0.0]);
    }
    let faces: Vec<[u32; 3]> = (0..k)
        .map(|i| [0, 1 + i as u32, 1 + ((i + 1) % k) as u32])
        .collect();
    let m = mesh(&pos, &faces);
    let colors = vec![[255, 255, 255]; pos.len()];
    for ss in [1, 2] {
        let img = render(&m, &colors, &plain(97, ss)).expect("render");
        // Inside the inscribed polygon (radius cos(π/k)), with a pixel of slack, every pixel is
        // fully covered.
        let s = scale(97, 1.0);
        let inner = (std::f64::consts::PI / k as f64).cos() * s - 1.5;
        for y in 0..97u32 {
            for x in 0..97u32 {
                let (dx, dy) = (x as f64 + 0.5 - 48.5, y as f64 + 0.5 - 48.5);
                if (dx * dx + dy * dy).sqrt() < inner {
                    assert_eq!(
                        img.pixel(x, y).expect("pixel"),
                        [255, 255, 255, 255],
                        "crack at ({x}, {y}), ss {ss}"
                    );
                }
            }
        }
    }
    // Double coverage: with a depth-tied fan, each sample is won by exactly one face; the total
    // coverage equals the polygon's area.
    let img = render(&m, &colors, &plain(200, 2)).expect("render");
    let covered: f64 = coverage(&img).iter().sum();
    let s = scale(200, 1.0);
    let area = 0.5 * k as f64 * (std::f64::consts::TAU / k as f64).sin() * s * s;
    assert!((covered - area).abs() < 0.005 * area, "{covered} vs {area}");
}

#[test]
fn sphere_renders_as_disc_of_the_right_radius() {
    let m = synth::icosphere(5, 2.5);
    let colors = vec![[255, 255, 255]; m.num_vertices()];
    for (az, el) in [(0.0, 0.0), (37.0, 61.0), (200.0, -30.0)] {
        let params = RenderParams {
            azimuth_deg: az,
            elevation_deg: el,
            ..plain(300, 2)
        };
        let img = render(&m, &colors, &params).expect("render");
        let r = scale(300, 2.5) * 2.5;
        // Lighting is ambient-only, so the disc is white and the coverage is the brightness.
        let area: f64 = coverage(&img).iter().sum();
        let expected = std::f64::consts::PI * r * r;
        assert!(
            (area - expected).abs() < 0.01 * expected,
            "view ({az}, {el}): {area} vs {expected}"
        );
        // Centred: the coverage's centroid is the image centre.
        let (mut mx, mut my) = (0.0, 0.0);
        for (i, c) in coverage(&img).iter().enumerate() {
            mx += c * ((i % 300) as f64 + 0.5);
            my += c * ((i / 300) as f64 + 0.5);
        }
        assert!((mx / area - 150.0).abs() < 0.5 && (my / area - 150.0).abs() < 0.5);
    }
}

#[test]
fn output_is_deterministic() {
    let m = synth::textured_protrusion_sphere(3);
    let colors: Vec<[u8; 3]> = m
        .positions
        .iter()
        .map(|p| [(p.x.abs() * 120.0) as u8, (p.y.abs() * 120.0) as u8, 200])
        .collect();
    let params = RenderParams {
        size: 160,
        ..RenderParams::default()
    };
    let a = render(&m, &colors, &params)
        .expect("a")
        .to_png_bytes()
        .expect("png");
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        let b = pool
            .install(|| render(&m, &colors, &params))
            .expect("b")
            .to_png_bytes()
            .expect("png");
        assert_eq!(a, b, "{threads} threads");
    }
}

fn decode(bytes: &[u8]) -> (u32, u32, png::ColorType, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("png frame");
    buf.truncate(info.buffer_size());
    (info.width, info.height, info.color_type, buf)
}

#[test]
fn png_round_trip() {
    let m = synth::torus(1.0, 0.35, 48, 24);
    let colors: Vec<[u8; 3]> = (0..m.num_vertices())
        .map(|i| {
            [
                (i * 7 % 256) as u8,
                (i * 13 % 256) as u8,
                (i * 29 % 256) as u8,
            ]
        })
        .collect();
    // Opaque: RGB.
    let img = render(
        &m,
        &colors,
        &RenderParams {
            size: 96,
            ..RenderParams::default()
        },
    )
    .expect("r");
    let (w, h, ct, data) = decode(&img.to_png_bytes().expect("png"));
    assert_eq!((w, h, ct), (96, 96, png::ColorType::Rgb));
    let rgb: Vec<u8> = img
        .pixels()
        .iter()
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    assert_eq!(data, rgb);
    // Transparent background: RGBA with partial alpha on the edges.
    let params = RenderParams {
        size: 96,
        background: [255, 255, 255, 0],
        ..RenderParams::default()
    };
    let img = render(&m, &colors, &params).expect("r");
    assert!(img.pixels().iter().any(|p| p[3] > 0 && p[3] < 255));
    assert_eq!(img.pixel(0, 0), Some([255, 255, 255, 0]));
    let dir = std::env::temp_dir().join(format!("keycomp-render-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("torus.png");
    img.write_png(&path).expect("write");
    let (w, h, ct, data) = decode(&std::fs::read(&path).expect("read"));
    assert_eq!((w, h, ct), (96, 96, png::ColorType::Rgba));
    assert_eq!(
        data,
        img.pixels().iter().flatten().copied().collect::<Vec<u8>>()
    );
    // Only the final file is left behind.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("torus.png")]);
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

/// An "L" in the z = 0 plane: a tall bar on the left and a foot to the right at the bottom.
fn letter_l() -> Mesh {
    mesh(
        &[
            [-0.6, -1.0, 0.0],
            [-0.2, -1.0, 0.0],
            [-0.2, 1.0, 0.0],
            [-0.6, 1.0, 0.0],
            [0.6, -1.0, 0.0],
            [0.6, -0.6, 0.0],
            [-0.2, -0.6, 0.0],
        ],
        &[[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 6]],
    )
}

fn mask(img: &Image) -> Vec<bool> {
    img.pixels().iter().map(|p| p[0] > 127).collect()
}

#[test]
fn azimuth_180_mirrors_left_and_right() {
    let m = letter_l();
    let colors = vec![[255, 255, 255]; 7];
    let n = 81usize;
    let front = mask(&render(&m, &colors, &plain(n as u32, 1)).expect("front"));
    let back = mask(
        &render(
            &m,
            &colors,
            &RenderParams {
                azimuth_deg: 180.0,
                ..plain(n as u32, 1)
            },
        )
        .expect("back"),
    );
    // The foot is on the right from the front…
    let right_half = |m: &[bool]| (0..n * n).filter(|&i| m[i] && i % n > n / 2).count();
    let left_half = |m: &[bool]| (0..n * n).filter(|&i| m[i] && i % n < n / 2).count();
    assert!(right_half(&front) > 0 && left_half(&front) > 2 * right_half(&front) / 3);
    // …and the back view is its mirror image (up to pixels exactly on an edge).
    let mut differ = 0;
    for y in 0..n {
        for x in 0..n {
            if front[y * n + x] != back[y * n + (n - 1 - x)] {
                differ += 1;
            }
        }
    }
    let total = front.iter().filter(|b| **b).count();
    assert!(differ * 100 < total, "{differ} of {total} differ");
    // Not upside down: the bar's top is in the upper half, the foot in the lower.
    let top_rows = (0..n * n / 3).filter(|&i| front[i]).count();
    assert!(top_rows > 0);
    let foot = (0..n * n)
        .filter(|&i| front[i] && i % n > 2 * n / 3)
        .map(|i| i / n)
        .min();
    assert!(foot.is_some_and(|row| row > n / 2), "{foot:?}");
}

#[test]
fn elevation_and_up_axis_orient_the_view() {
    // A bar along +Y is vertical in the picture with Y up.
    let bar = mesh(
        &[
            [-0.1, 0.0, -0.1],
            [0.1, 0.0, -0.1],
            [0.1, 1.0, -0.1],
            [-0.1, 1.0, -0.1],
        ],
        &[[0, 1, 2], [0, 2, 3]],
    );
    let colors = vec![[255, 255, 255]; 4];
    let img = render(&bar, &colors, &plain(64, 1)).expect("y-up");
    let m = mask(&img);
    let rows: Vec<usize> = (0..64 * 64).filter(|&i| m[i]).map(|i| i / 64).collect();
    let cols: Vec<usize> = (0..64 * 64).filter(|&i| m[i]).map(|i| i % 64).collect();
    let span =
        |v: &[usize]| v.iter().max().copied().unwrap_or(0) - v.iter().min().copied().unwrap_or(0);
    assert!(span(&rows) > 4 * span(&cols), "vertical bar");
    // With Z up, a bar along +Z (facing the front camera at −Y) is vertical.
    let bar_z = mesh(
        &[
            [-0.1, 0.1, 0.0],
            [0.1, 0.1, 0.0],
            [0.1, 0.1, 1.0],
            [-0.1, 0.1, 1.0],
        ],
        &[[0, 1, 2], [0, 2, 3]],
    );
    let params = RenderParams {
        up: UpAxis::Z,
        ..plain(64, 1)
    };
    let img = render(&bar_z, &colors, &params).expect("z-up");
    let m = mask(&img);
    let rows: Vec<usize> = (0..64 * 64).filter(|&i| m[i]).map(|i| i / 64).collect();
    let cols: Vec<usize> = (0..64 * 64).filter(|&i| m[i]).map(|i| i % 64).collect();
    assert!(span(&rows) > 4 * span(&cols), "vertical bar with Z up");

    // A sphere with a red cap at +Y: from the side the red is at the top; from below
    // (elevation −90) it is hidden; from above it fills the centre.
    let s = synth::icosphere(3, 1.0);
    let colors: Vec<[u8; 3]> = s
        .positions
        .iter()
        .map(|p| if p.y > 0.8 { [255, 0, 0] } else { [0, 0, 255] })
        .collect();
    let side = render(&s, &colors, &plain(64, 1)).expect("side");
    let red_rows: Vec<u32> = (0..64 * 64)
        .filter(|&i| side.pixels()[i as usize][0] > 128)
        .map(|i| i / 64)
        .collect();
    assert!(
        !red_rows.is_empty() && red_rows.iter().all(|&r| r < 20),
        "{red_rows:?}"
    );
    let above = render(
        &s,
        &colors,
        &RenderParams {
            elevation_deg: 90.0,
            ..plain(64, 1)
        },
    )
    .expect("above");
    assert!(above.pixel(32, 32).expect("c")[0] > 128);
    let below = render(
        &s,
        &colors,
        &RenderParams {
            elevation_deg: -90.0,
            ..plain(64, 1)
        },
    )
    .expect("below");
    assert!(below.pixels().iter().all(|p| p[0] < 128));
}

#[test]
fn lighting_and_outline_change_the_picture() {
    let m = synth::icosphere(4, 1.0);
    let colors = vec![[200, 200, 200]; m.num_vertices()];
    let lit = RenderParams {
        size: 128,
        ambient: 0.4,
        ..RenderParams::default()
    };
    let img = render(&m, &colors, &lit).expect("lit");
    // The key light comes from the upper left: that side is brighter than the lower right.
    let ul = img.pixel(40, 40).expect("ul")[0];
    let lr = img.pixel(88, 88).expect("lr")[0];
    assert!(ul > lr + 20, "{ul} vs {lr}");
    // The outline darkens the rim; without it, the rim keeps the surface colour.
    let edge = |img: &Image| {
        (0..128)
            .filter_map(|x| {
                let p = img.pixel(x, 64)?;
                (p[0] < 60).then_some(x)
            })
            .count()
    };
    // Unlit surface is at least 0.4 · 200 = 80, so only outline pixels are this dark.
    assert!(edge(&img) >= 2);
    let no_outline = render(
        &m,
        &colors,
        &RenderParams {
            outline: None,
            ..lit
        },
    )
    .expect("plain");
    assert_eq!(edge(&no_outline), 0);
    // A cube's creases are outlined with flat shading.
    let cube = synth::cuboid([-1.0; 3], [2.0; 3]);
    let params = RenderParams {
        size: 128,
        shading: Shading::Flat,
        outline: Some(Outline::default()),
        ..RenderParams::default()
    };
    let img = render(&cube, &[[220, 220, 220]; 8], &params).expect("cube");
    let dark = img.pixels().iter().filter(|p| p[0] < 100).count();
    // Silhouette (~4 × 100 px) plus three inner creases.
    assert!(dark > 350, "{dark}");
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = synth::icosphere(1, 1.0);
    let ok = vec![[0, 0, 0]; m.num_vertices()];
    assert!(matches!(
        render(&m, &ok[1..], &RenderParams::default()),
        Err(RenderError::ColorCount { .. })
    ));
    for params in [
        RenderParams {
            size: 0,
            ..RenderParams::default()
        },
        RenderParams {
            supersampling: 9,
            ..RenderParams::default()
        },
        RenderParams {
            elevation_deg: 91.0,
            ..RenderParams::default()
        },
        RenderParams {
            azimuth_deg: f64::NAN,
            ..RenderParams::default()
        },
        RenderParams {
            margin: 0.5,
            ..RenderParams::default()
        },
    ] {
        let err = render(&m, &ok, &params).expect_err("invalid");
        assert!(matches!(err, RenderError::InvalidParam { .. }), "{err}");
    }
    let mut bad = m.clone();
    bad.faces[3][1] = 10_000;
    assert!(matches!(
        render(&bad, &ok, &RenderParams::default()),
        Err(RenderError::FaceIndex { face: 3, .. })
    ));
    let mut bad = m.clone();
    bad.positions[5].x = f64::NAN;
    assert!(matches!(
        render(&bad, &ok, &RenderParams::default()),
        Err(RenderError::NonFinite { vertex: 5 })
    ));
    // No faces: just the background.
    let empty = Mesh {
        positions: m.positions.clone(),
        faces: vec![],
    };
    let img = render(
        &empty,
        &ok,
        &RenderParams {
            size: 8,
            ..RenderParams::default()
        },
    )
    .expect("empty");
    assert!(img.pixels().iter().all(|p| *p == [255, 255, 255, 255]));
    // Writing into a missing directory names the path.
    let err = img
        .write_png(std::path::Path::new("/nonexistent-dir/x.png"))
        .expect_err("missing dir");
    assert!(err.to_string().contains("/nonexistent-dir/x.png"), "{err}");
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// A quadrilateral split into 2 triangles along a diagonal and into 4 triangles around a
        /// random interior point covers exactly the same samples, from any view: shared edges
        /// leave no cracks and no sample is claimed twice or lost.
        #[test]
        fn splitting_a_quad_changes_no_sample(
            u in 0.05f64..0.95,
            v in 0.05f64..0.95,
            skew in -0.3f64..0.3,
            az in -70.0f64..70.0,
            el in -70.0f64..70.0,
        ) {
            let corners = [
                [-1.0, -1.0, 0.0],
                [1.0 + skew, -1.0, 0.2],
                [1.0, 1.0 - skew, 0.0],
                [-1.0, 1.0, -0.2 * skew],
            ];
            // An interior point as a bilinear blend of the corners (inside the convex quad).
            let lerp = |a: [f64; 3], b: [f64; 3], t: f64| [0, 1, 2].map(|k| a[k] + t * (b[k] - a[k]));
            let centre = lerp(lerp(corners[0], corners[1], u), lerp(corners[3], corners[2], u), v);
            let mut pos = corners.to_vec();
            pos.push(centre);
            let two = mesh(&pos, &[[0, 1, 2], [0, 2, 3]]);
            let four = mesh(&pos, &[[4, 0, 1], [4, 1, 2], [4, 2, 3], [4, 3, 0]]);
            let colors = vec![[255, 255, 255]; 5];
            let params = RenderParams { azimuth_deg: az, elevation_deg: el, ..plain(64, 1) };
            let a = render(&two, &colors, &params).expect("two");
            let b = render(&four, &colors, &params).expect("four");
            prop_assert_eq!(mask(&a), mask(&b));
            prop_assert!(a.pixels().iter().all(|p| p[0] == 0 || p[0] == 255));
        }

        /// The same with every vertex on a sample centre, so many samples lie exactly on shared
        /// edges and only the fill rule decides them; faces randomly wound either way.
        #[test]
        fn splitting_a_rectangle_on_sample_centres_changes_no_sample(
            a in -11i32..=11,
            b in -15i32..=15,
            flips in proptest::collection::vec(any::<bool>(), 6),
        ) {
            // Image 65 px, rectangle ±3 × ±4 (bounding radius 5), margin chosen so that one
            // world unit is 4 pixels: sample centres are exactly the points (i/4, j/4).
            let params = RenderParams { margin: (1.0 - 4.0 * 5.0 / 32.5) / 2.0, ..plain(65, 1) };
            let pos = [
                [-3.0, -4.0, 0.0],
                [3.0, -4.0, 0.0],
                [3.0, 4.0, 0.0],
                [-3.0, 4.0, 0.0],
                [f64::from(a) / 4.0, f64::from(b) / 4.0, 0.0],
            ];
            let wind = |faces: &[[u32; 3]]| -> Vec<[u32; 3]> {
                faces
                    .iter()
                    .zip(&flips)
                    .map(|(f, &flip)| if flip { [f[0], f[2], f[1]] } else { *f })
                    .collect()
            };
            let two = mesh(&pos, &wind(&[[0, 1, 2], [0, 2, 3]]));
            let four = mesh(&pos, &wind(&[[4, 0, 1], [4, 1, 2], [4, 2, 3], [4, 3, 0]]));
            let colors = vec![[255, 255, 255]; 5];
            let ma = mask(&render(&two, &colors, &params).expect("two"));
            let mb = mask(&render(&four, &colors, &params).expect("four"));
            // The rectangle's samples: centres with |x| ≤ 3, |y| ≤ 4 minus the right and bottom
            // edges (not top-left): 24 × 32.
            prop_assert_eq!(ma.iter().filter(|m| **m).count(), 24 * 32);
            prop_assert_eq!(ma, mb);
        }
    }
}
