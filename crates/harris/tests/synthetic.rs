//! Harris 3D on synthetic meshes with known answers: analytic quadrics, protrusion tips,
//! invariance under rigid motions and scaling, and properties of random height fields.

use keycomp_harris::{
    HarrisParams, LengthReference, Neighborhood, Selection, UnitArea, detect, detect_in,
    harris_response, local_fit, local_maxima, select_keypoints, smoothing_passes,
};
use keycomp_mesh::geometry::total_area;
use keycomp_mesh::{Mesh, Point3, Topology, Vector3, synth};
use nalgebra::Rotation3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Vertices within `k` edge rings of `v`.
fn ring(topo: &Topology, v: u32, k: usize) -> Vec<u32> {
    let mut mark = vec![false; topo.num_vertices()];
    let mut out = Vec::new();
    topo.rings(v, k, &mut mark, &mut out);
    out
}

/// Moves every vertex radially by a seeded random amount in [−amp, amp] (breaks the exact
/// symmetries of an icosphere, so no two responses are equal by construction).
fn jitter(mesh: &Mesh, amp: f64, seed: u64) -> Mesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut m = mesh.clone();
    for p in &mut m.positions {
        let u = p.coords.normalize();
        *p += u * rng.random_range(-amp..amp);
    }
    m
}

#[test]
fn paraboloid_apex_frame_and_curvature() {
    // z = a x² + c y² on a grid centred on the apex (vertex 20·41 + 20)
    let (a, c) = (0.8, 0.3);
    let m = synth::height_field(40, 40, 0.05, |x, y| a * x * x + c * y * y);
    let t = Topology::new(&m);
    let apex = 20 * 41 + 20;
    assert_eq!(m.positions[apex as usize], Point3::origin());
    let s = 1.0 / total_area(&m).sqrt(); // unit-area scale
    for params in [
        HarrisParams::default(),
        HarrisParams {
            neighborhood: Neighborhood::Rings(3),
            ..HarrisParams::default()
        },
    ] {
        let fit = local_fit(&m, &t, &params, apex).expect("apex has a fit");
        let [x, y, z] = fit.frame;
        // the normal is vertical, oriented away from the (higher) centroid: −z
        assert!((z - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-9, "z {z:?}");
        assert!(x.z.abs() < 1e-9 && y.z.abs() < 1e-9);
        assert!((x.cross(&y) - z).norm() < 1e-12, "right-handed");
        // The surface is exactly quadratic and the frame exact, so the fit is exact: the
        // Hessian [[p1, p2], [p2, p3]] has eigenvalues −2a/s, −2c/s (in unit-area units; the
        // in-plane axes are free by symmetry, so compare trace and determinant).
        let [p1, p2, p3, p4, p5, p6] = fit.coefficients;
        let (ka, kc) = (-2.0 * a / s, -2.0 * c / s);
        assert!(
            ((p1 + p3) - (ka + kc)).abs() < 1e-8,
            "{:?}",
            fit.coefficients
        );
        assert!(((p1 * p3 - p2 * p2) - ka * kc).abs() < 1e-8);
        assert!(p4.abs() < 1e-9 && p5.abs() < 1e-9 && p6.abs() < 1e-9);
        assert!(fit.num_points >= params.min_points);
    }
}

#[test]
fn sphere_curvature_within_discretisation_tolerance() {
    let m = synth::icosphere(5, 3.0);
    let t = Topology::new(&m);
    let s = 1.0 / total_area(&m).sqrt();
    let kappa = 1.0 / (3.0 * s); // curvature in unit-area units
    let p = HarrisParams::default();
    for v in [0u32, 17, 5000, 10241] {
        let fit = local_fit(&m, &t, &p, v).expect("fit");
        let [p1, p2, p3, ..] = fit.coefficients;
        // the frame's z points outwards, so the surface bends towards −z: p1 = p3 = −κ
        let outward = m.positions[v as usize].coords.normalize();
        assert!(fit.frame[2].dot(&outward) > 0.999);
        for q in [p1, p3] {
            assert!((q + kappa).abs() < 0.02 * kappa, "{q} vs −{kappa}");
        }
        assert!(p2.abs() < 0.02 * kappa);
    }
    // responses all near 4κ⁴(1 − 4k): a sphere has no preferred point
    let r = harris_response(&m, &t, &p);
    let want = 4.0 * kappa.powi(4) * (1.0 - 4.0 * p.k);
    assert!(r.iter().all(|h| (h - want).abs() < 0.1 * want));
}

#[test]
fn keypoints_sit_on_the_protrusion_tips() {
    for sub in [4, 5] {
        let m = synth::protrusion_sphere(sub, 0.8, 0.25);
        let t = Topology::new(&m);
        let tips = synth::protrusion_tips(&m);
        let p = HarrisParams {
            selection: Selection::Count(6),
            ..HarrisParams::default()
        };
        let res = detect(&m, &t, &p).expect("valid");
        assert_eq!(res.keypoints.len(), 6);
        for &tip in &tips {
            let near = ring(&t, tip, 2);
            assert!(
                res.keypoints.iter().any(|k| near.contains(k)),
                "sub {sub}: no keypoint within 2 rings of tip {tip}: {:?}",
                res.keypoints
            );
        }
        // The tips respond far more strongly than anything on the sphere or the bump flanks:
        // the weakest tip beats the strongest vertex that is not on a protrusion.
        let tip_min = tips
            .iter()
            .map(|&v| res.response[v as usize])
            .fold(f64::INFINITY, f64::min);
        let body_max = (0..m.num_vertices())
            .filter(|&v| m.positions[v].coords.norm() < 1.3)
            .map(|v| res.response[v])
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(tip_min > 10.0 * body_max, "{tip_min} vs {body_max}");
        // and the response is positive (corner-like) at tips, negative along the flanks
        // somewhere (edge-like ridges around each bump), as the formula predicts
        assert!(tip_min > 0.0);
        assert!(res.response.iter().any(|&h| h < 0.0));
    }
}

/// Applies `f` to every vertex.
fn moved(mesh: &Mesh, f: impl Fn(Point3<f64>) -> Point3<f64>) -> Mesh {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        *p = f(*p);
    }
    m
}

#[test]
fn keypoints_are_invariant_to_rotation_translation_and_scale() {
    // A dense jittered protrusion sphere: adaptive neighbourhoods span several rings, so a
    // rotation-dependent radius would show. Expected: the identical keypoint list. The
    // computation only uses differences p − v scaled to unit area and a rotation-invariant
    // length (the moment diagonal), so moved copies differ only by floating-point rounding of
    // the moved coordinates (responses agree to ~1e-6 relative after a 1000-unit shift, 1e-9
    // otherwise); jitter removes exact ties, so rounding cannot reorder the selection.
    let base = jitter(&synth::protrusion_sphere(5, 0.8, 0.25), 0.002, 11);
    let t = Topology::new(&base);
    let p = HarrisParams::default();
    let r0 = detect(&base, &t, &p).expect("valid");
    assert!(r0.keypoints.len() > 50);
    let rot = Rotation3::from_euler_angles(0.3, 1.1, -0.7);
    let shift = Vector3::new(1000.0, -1000.0, 1000.0);
    let cases: Vec<(&str, Mesh)> = vec![
        ("rotation", moved(&base, |q| rot * q)),
        ("translation by 1000", moved(&base, |q| q + shift)),
        ("scale 0.001", moved(&base, |q| q * 0.001)),
        ("scale 1000", moved(&base, |q| q * 1000.0)),
        (
            "all at once",
            moved(&base, |q| (rot * q) * 1000.0 + shift * 7.0),
        ),
    ];
    for (name, m) in cases {
        let r = detect(&m, &t, &p).expect("valid");
        assert_eq!(r.keypoints, r0.keypoints, "{name}");
        for (a, b) in r0.response.iter().zip(&r.response) {
            assert!(
                (a - b).abs() <= 1e-5 * a.abs().max(1.0),
                "{name}: {a} vs {b}"
            );
        }
    }
    // The authors' bounding-box radius is translation and scale invariant here but not
    // rotation invariant; it must still give the same keypoints under translation.
    let pb = HarrisParams {
        length_reference: LengthReference::BoundingBoxDiagonal,
        ..p
    };
    let b0 = detect(&base, &t, &pb).expect("valid");
    let b1 = detect(&moved(&base, |q| q + shift), &t, &pb).expect("valid");
    assert_eq!(b0.keypoints, b1.keypoints);
}

#[test]
fn neighbourhood_rules() {
    // coarse mesh: the radius is below one edge, so min_rings = 2 decides (a 2-ring)
    let m = synth::icosphere(3, 1.0);
    let t = Topology::new(&m);
    let p = HarrisParams::default();
    let f = local_fit(&m, &t, &p, 0).expect("fit");
    assert_eq!(f.rings, 2);
    assert_eq!(f.num_points, ring(&t, 0, 2).len());
    // min_rings = 1 (the authors' rule) with a low point floor: only the 1-ring (6 + 1 points)
    let one = HarrisParams {
        min_rings: 1,
        min_points: 6,
        ..p
    };
    assert_eq!(local_fit(&m, &t, &one, 0).expect("fit").num_points, 6);
    // a larger radius takes more rings
    let wide = HarrisParams {
        neighborhood: Neighborhood::Adaptive {
            radius_fraction: 0.2,
        },
        ..p
    };
    assert!(local_fit(&m, &t, &wide, 0).expect("fit").rings > 2);
    // grid corner: 2 rings hold 6 points, so rings are added up to ≥ 12 points
    let g = synth::grid(10, 10, 1.0);
    let tg = Topology::new(&g);
    let corner = local_fit(&g, &tg, &p, 0).expect("fit");
    assert!(corner.num_points >= 12 && corner.rings > 2, "{corner:?}");
    // fixed rings
    let r3 = HarrisParams {
        neighborhood: Neighborhood::Rings(3),
        ..p
    };
    assert_eq!(local_fit(&g, &tg, &r3, 60).expect("fit").rings, 3);
}

#[test]
fn vertices_without_a_response_are_nan_and_never_selected() {
    // an icosphere, a lone triangle (too few points for a fit) and an unreferenced vertex
    let mut m = synth::icosphere(2, 1.0);
    let n = m.num_vertices() as u32;
    m.positions.extend([
        Point3::new(5.0, 0.0, 0.0),
        Point3::new(6.0, 0.0, 0.0),
        Point3::new(5.0, 1.0, 0.0),
        Point3::new(9.0, 9.0, 9.0),
    ]);
    m.faces.push([n, n + 1, n + 2]);
    let t = Topology::new(&m);
    let res = detect(
        &m,
        &t,
        &HarrisParams {
            selection: Selection::Fraction(1.0),
            ..HarrisParams::default()
        },
    )
    .expect("valid");
    for v in n..n + 4 {
        assert!(res.response[v as usize].is_nan());
        assert!(!res.keypoints.contains(&v));
    }
    assert!(res.response[..n as usize].iter().all(|h| h.is_finite()));
    // a mismatched topology is an error from detect and NaN from harris_response
    let other = Topology::new(&synth::icosphere(1, 1.0));
    assert!(detect(&m, &other, &HarrisParams::default()).is_err());
    assert!(
        harris_response(&m, &other, &HarrisParams::default())
            .iter()
            .all(|h| h.is_nan())
    );
}

#[test]
fn selection_modes() {
    let m = jitter(&synth::protrusion_sphere(4, 0.8, 0.25), 0.002, 3);
    let t = Topology::new(&m);
    let p = HarrisParams::default();
    let r = harris_response(&m, &t, &p);
    let cands = local_maxima(&t, &r);
    // 1 % of 2562 vertices = 25.62 → 26
    let frac = select_keypoints(&m, &t, &r, &Selection::Fraction(0.01));
    assert_eq!(frac.len(), 26.min(cands.len()));
    assert_eq!(&frac[..], &cands[..frac.len()]);
    let all = select_keypoints(&m, &t, &r, &Selection::Fraction(1.0));
    assert_eq!(all, cands);
    let spaced = select_keypoints(
        &m,
        &t,
        &r,
        &Selection::Spacing {
            fraction_of_diagonal: 0.2,
            max: None,
        },
    );
    // the spacing exceeds each bump's size, so one keypoint per protrusion plus a few on the
    // sphere, every pair far apart
    let d = keycomp_harris::moment_diagonal(&m) * 0.2;
    for (i, &a) in spaced.iter().enumerate() {
        for &b in &spaced[..i] {
            assert!((m.positions[a as usize] - m.positions[b as usize]).norm() >= d);
        }
    }
    assert_eq!(spaced[0], cands[0]);
    let tips = synth::protrusion_tips(&m);
    for tip in tips {
        let near = ring(&t, tip, 3);
        assert!(spaced.iter().any(|k| near.contains(k)));
    }
    let capped = select_keypoints(
        &m,
        &t,
        &r,
        &Selection::Spacing {
            fraction_of_diagonal: 0.2,
            max: Some(3),
        },
    );
    assert_eq!(&capped[..], &spaced[..3]);
}

/// A random height field on a small grid (with random cell size and amplitude).
fn random_height_field() -> impl Strategy<Value = Mesh> {
    (
        2usize..9,
        2usize..9,
        0.01f64..10.0,
        prop::collection::vec(-1.0f64..1.0, 100),
    )
        .prop_map(|(nx, ny, cell, h)| {
            let mut m = synth::grid(nx, ny, cell);
            for (i, p) in m.positions.iter_mut().enumerate() {
                p.z = h[i % h.len()] * cell;
            }
            m
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn responses_and_keypoints_are_well_formed(m in random_height_field(), frac in 0.01f64..1.0) {
        let t = Topology::new(&m);
        let p = HarrisParams { selection: Selection::Fraction(frac), ..HarrisParams::default() };
        let res = detect(&m, &t, &p).expect("valid");
        prop_assert_eq!(res.response.len(), m.num_vertices());
        // a grid piece has ≥ 9 vertices; with fewer than min_points the whole piece is NaN,
        // otherwise every vertex has a finite response (no rank-deficient patches here)
        let expect_nan = m.num_vertices() < p.min_points;
        for &h in &res.response {
            prop_assert_eq!(h.is_nan(), expect_nan);
            prop_assert!(!h.is_infinite());
        }
        let mut seen = std::collections::HashSet::new();
        for &k in &res.keypoints {
            prop_assert!(seen.insert(k), "duplicate keypoint {}", k);
            let h = res.response[k as usize];
            prop_assert!(h.is_finite());
            for &w in t.neighbors(k) {
                let rw = res.response[w as usize];
                prop_assert!(rw <= h || rw.is_nan(), "keypoint {} not a local max", k);
            }
        }
        // best first, ties by id
        for w in res.keypoints.windows(2) {
            let (a, b) = (res.response[w[0] as usize], res.response[w[1] as usize]);
            prop_assert!(a > b || (a == b && w[0] < w[1]));
        }
        let cands = local_maxima(&t, &res.response);
        let budget = ((frac * m.num_vertices() as f64).round() as usize).max(1);
        prop_assert_eq!(res.keypoints.len(), budget.min(cands.len()));
    }
}

/// Coefficient of variation of the finite responses.
fn spread_of(r: &[f64]) -> f64 {
    let v: Vec<f64> = r.iter().copied().filter(|x| x.is_finite()).collect();
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64;
    var.sqrt() / mean.abs()
}

#[test]
fn smoothing_removes_the_responses_of_noise() {
    // On a sphere every point is alike, so the exact responses are uniform; radial noise of a
    // fifth of an edge makes them vary, and smoothing the copy they are computed on takes most
    // of that back out.
    let clean = synth::icosphere(5, 1.0);
    let noisy = jitter(&clean, 0.2 * 0.024, 3);
    let topo = Topology::new(&noisy);
    let plain = HarrisParams::default();
    let smoothed = HarrisParams {
        smoothing_iterations: 30,
        ..plain
    };
    let (raw, smooth) = (
        harris_response(&noisy, &topo, &plain),
        harris_response(&noisy, &topo, &smoothed),
    );
    let clean_spread = spread_of(&harris_response(&clean, &Topology::new(&clean), &plain));
    let (a, b) = (spread_of(&raw), spread_of(&smooth));
    assert!(
        b < 0.5 * a,
        "noise spread {a}, smoothed {b} (clean {clean_spread})"
    );
    // zero iterations is the paper's method: the very same responses
    let zero = HarrisParams {
        smoothing_iterations: 0,
        ..plain
    };
    assert_eq!(
        harris_response(&noisy, &topo, &zero)
            .iter()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>(),
        raw.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
    // keypoints stay vertices of the input, and `detect` validates the new field
    let result = detect(&noisy, &topo, &smoothed).expect("valid");
    assert!(
        result
            .keypoints
            .iter()
            .all(|&k| (k as usize) < noisy.num_vertices())
    );
    let bad = HarrisParams {
        smoothing_iterations: 5000,
        ..plain
    };
    assert!(detect(&noisy, &topo, &bad).is_err());
}

#[test]
fn smoothing_lowers_a_spike_against_real_features() {
    // shot noise: on a sphere with six smooth protrusions, the body vertex farthest from
    // every protrusion pushed out by a twentieth of the radius. Smoothing the copy the
    // responses are computed on lowers the spike's response against the protrusion tips'
    // several times over (about 7× on this mesh).
    let mut m = synth::protrusion_sphere(4, 0.8, 0.25);
    let dirs = synth::protrusion_directions();
    let spike = (0..m.num_vertices() as u32)
        .max_by(|&a, &b| {
            let far = |v: u32| {
                let u = m.positions[v as usize].coords.normalize();
                dirs.iter().map(|d| u.dot(d)).fold(f64::MIN, f64::max)
            };
            far(b).total_cmp(&far(a))
        })
        .expect("vertices");
    let p = m.positions[spike as usize];
    m.positions[spike as usize] = Point3::from(p.coords * 1.05);
    let topo = Topology::new(&m);
    let params = HarrisParams {
        selection: Selection::Count(1),
        ..HarrisParams::default()
    };
    let tips = synth::protrusion_tips(&m);
    let near: Vec<u32> = ring(&topo, spike, 2);
    // the strongest response around the spike over the strongest at a protrusion tip
    let ratio = |h: &HarrisParams| {
        let r = harris_response(&m, &topo, h);
        let at = |vs: &[u32]| vs.iter().map(|&v| r[v as usize]).fold(f64::MIN, f64::max);
        at(&near) / at(&tips)
    };
    let smoothed = HarrisParams {
        smoothing_iterations: 30,
        ..params
    };
    let (before, after) = (ratio(&params), ratio(&smoothed));
    assert!(
        before > 0.0 && after < 0.25 * before,
        "plain {before}, smoothed {after}"
    );
    // the best keypoint is a tip either way
    for h in [params, smoothed] {
        let best = detect(&m, &topo, &h).expect("valid").keypoints[0];
        assert!(
            tips.iter().any(|&t| ring(&topo, t, 2).contains(&best)),
            "{best}"
        );
    }
}

/// In a given unit (the area of the shape a mesh stands for), responses and keypoints are
/// those of the mesh scaled by that unit: a copy scaled by s and given a unit s² times larger
/// gets the same keypoints, and a mesh given its own area as unit is measured as with
/// `UnitArea::Own`. Unit-length radii and smoothing lengths follow the unit, not the mesh.
#[test]
fn a_given_unit_area_measures_the_mesh_in_that_unit() {
    let base = jitter(&synth::protrusion_sphere(5, 0.8, 0.25), 0.002, 11);
    let t = Topology::new(&base);
    let p = HarrisParams {
        neighborhood: Neighborhood::Adaptive {
            radius_fraction: 0.05,
        },
        length_reference: LengthReference::Unit,
        selection: Selection::PerArea(120.0),
        smoothing_length: Some(0.05),
        ..HarrisParams::default()
    };
    let own = detect(&base, &t, &p).expect("valid");
    let area = total_area(&base);
    let given = detect_in(&base, &t, &p, UnitArea::Given(area)).expect("valid");
    assert_eq!(own.keypoints, given.keypoints);
    assert_eq!(own.keypoints.len(), 120);
    let scaled = moved(&base, |q| q * 3.0);
    let r = detect_in(&scaled, &t, &p, UnitArea::Given(9.0 * area)).expect("valid");
    assert_eq!(r.keypoints, own.keypoints);
    for (a, b) in own.response.iter().zip(&r.response) {
        assert!((a - b).abs() <= 1e-6 * a.abs().max(1.0), "{a} vs {b}");
    }
    // taken for a quarter of a shape four times its area: a quarter of the keypoints, and
    // larger radii and smoothing in its own frame, so other responses
    let quarter = detect_in(&base, &t, &p, UnitArea::Given(4.0 * area)).expect("valid");
    assert_eq!(quarter.keypoints.len(), 30);
    assert_ne!(quarter.response, own.response);
    // an invalid unit is refused, never a panic
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(detect_in(&base, &t, &p, UnitArea::Given(bad)).is_err());
    }
}

/// A smoothing length gives `round((ℓ / ē)⁴)` passes for the mean edge ē in the unit's
/// frame: the same surface at twice the resolution gets sixteen times the passes.
#[test]
fn smoothing_lengths_become_passes_by_the_mean_edge() {
    let coarse = synth::grid(20, 20, 0.05); // area 1, edges 0.05 and 0.05·√2
    let fine = synth::grid(40, 40, 0.025);
    let passes =
        |m: &Mesh, l: f64| smoothing_passes(m, &Topology::new(m), 7, Some(l), UnitArea::Own);
    let (c, f) = (passes(&coarse, 0.13), passes(&fine, 0.13));
    assert!((20..=40).contains(&c), "{c}");
    assert!((f as f64 / c as f64 - 16.0).abs() < 1.0, "{c} then {f}");
    // without a length the count applies; never beyond the bound
    assert_eq!(
        smoothing_passes(&coarse, &Topology::new(&coarse), 7, None, UnitArea::Own),
        7
    );
    assert_eq!(passes(&coarse, 1e9), HarrisParams::MAX_SMOOTHING_ITERATIONS);
    assert_eq!(passes(&coarse, 0.0), 0);
}
