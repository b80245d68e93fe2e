//! Built-in shape collection for keycomp's demo and tests: organic shapes with protrusions
//! (animals, a humanoid, an octopus, a mug, …) generated in code, deterministic for a seed.
//!
//! Each shape is the smooth union ([`sdf::smooth_min`]) of ellipsoids and tapered capsules
//! laid out on a class skeleton ([`Class`]) whose proportions, limb lengths, thicknesses and
//! pose angles are drawn from a seeded ChaCha8 generator, meshed from the implicit surface by
//! marching tetrahedra ([`mesher`]) at a cell size chosen for a target vertex count, then
//! moved by a random rigid motion and scale. Every generated mesh is checked
//! ([`check::check_closed_manifold`]): closed, manifold, consistently oriented outwards, one
//! piece, of its class's genus, with no degenerate face; a shape failing the check is an
//! error, never returned.
//!
//! ```
//! use keycomp_shapes::{Class, GenerateParams, generate};
//! let params = GenerateParams { target_vertices: 4000, ..GenerateParams::default() };
//! let shape = generate(Class::Octopus, 0, &params)?;
//! assert_eq!(shape.name, "octopus-00");
//! assert!(shape.mesh.num_vertices() > 3000);
//! # Ok::<(), keycomp_shapes::ShapesError>(())
//! ```

pub mod check;
mod classes;
mod error;
pub mod mesher;
pub mod sdf;

pub use classes::Class;
pub use error::ShapesError;

use keycomp_mesh::{Mesh, Point3, Vector3};
use nalgebra::{Quaternion, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::mesher::{MeshParams, mesh_implicit};

/// Smallest [`GenerateParams::target_vertices`]: below it the grid cells approach the
/// thickness of wings, fins and tentacle tips, which can then break off or close into tunnels.
pub const MIN_VERTICES: usize = 4000;

/// Parameters of [`generate`] and [`collection`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GenerateParams {
    /// Seed of the whole collection (default 2013). Instance `i` of class `c` is drawn from its
    /// own generator seeded by `(seed, c, i)`, so it does not depend on how many shapes are
    /// generated.
    pub seed: u64,
    /// Vertex count aimed at (default 20 000; results land within about ±10 %). Lower it for
    /// fast tests; at least [`MIN_VERTICES`].
    pub target_vertices: usize,
    /// Relaxation rounds of the mesher (default 4).
    pub relax_rounds: usize,
    /// Apply a random rotation, scale (0.8–1.25) and translation (default true).
    pub rigid_motion: bool,
}

impl Default for GenerateParams {
    fn default() -> Self {
        GenerateParams {
            seed: 2013,
            target_vertices: 20_000,
            relax_rounds: 4,
            rigid_motion: true,
        }
    }
}

/// One generated shape.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// `class-NN`, e.g. `bird-04`.
    pub name: String,
    /// Its class.
    pub class: Class,
    /// Instance number within the class.
    pub instance: usize,
    /// The closed triangle mesh.
    pub mesh: Mesh,
}

fn rng_for(seed: u64, class: Class, instance: usize) -> ChaCha8Rng {
    let c = Class::ALL.iter().position(|&k| k == class).unwrap_or(0) as u64;
    // SplitMix-style mixing of the three numbers into one seed.
    let mut z = seed
        .wrapping_add(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(c + 1))
        .wrapping_add(0xBF58_476D_1CE4_E5B9u64.wrapping_mul(instance as u64 + 1));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ChaCha8Rng::seed_from_u64(z ^ (z >> 31))
}

/// A uniformly random rotation (K. Shoemake, "Uniform random rotations", Graphics Gems III,
/// 1992).
fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let tau = std::f64::consts::TAU;
    UnitQuaternion::from_quaternion(Quaternion::new(
        b * (tau * u3).cos(),
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
    ))
}

/// Generates instance `instance` of `class` (see the crate documentation).
///
/// The cell size comes from a coarse pass: marching tetrahedra's vertex count grows as area/h²,
/// so a mesh at cell `h0` with `V0` vertices gives `h = h0·√(V0 / target)`.
pub fn generate(
    class: Class,
    instance: usize,
    params: &GenerateParams,
) -> Result<Shape, ShapesError> {
    if params.target_vertices < MIN_VERTICES {
        return Err(ShapesError::Params(format!(
            "target_vertices must be at least {MIN_VERTICES} (coarser grids cannot resolve the thinnest parts), got {}",
            params.target_vertices
        )));
    }
    let mut rng = rng_for(params.seed, class, instance);
    let solid = class.solid(&mut rng);
    let (lo, hi) = solid.bounds();
    let field = |p: &Point3<f64>| solid.field(p);
    let h0 = (hi - lo).norm() / 60.0;
    let coarse = mesh_implicit(
        &field,
        lo,
        hi,
        &MeshParams {
            cell: h0,
            relax_rounds: 0,
        },
    )?;
    let h = h0 * (coarse.num_vertices() as f64 / params.target_vertices as f64).sqrt();
    let mut mesh = mesh_implicit(
        &field,
        lo,
        hi,
        &MeshParams {
            cell: h,
            relax_rounds: params.relax_rounds,
        },
    )?;
    if params.rigid_motion {
        let rot = random_rotation(&mut rng);
        let scale = rng.random_range(0.8..1.25);
        let shift = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        for p in &mut mesh.positions {
            *p = Point3::from(rot * p.coords * scale + shift);
        }
    }
    let name = format!("{}-{instance:02}", class.name());
    let report =
        check::check_closed_manifold(&mesh).map_err(|problem| ShapesError::InvalidSurface {
            name: name.clone(),
            problem,
        })?;
    let expected = 2 - 2 * class.genus();
    if report.components != 1 || report.euler != expected || report.signed_volume <= 0.0 {
        return Err(ShapesError::InvalidSurface {
            name,
            problem: format!(
                "{} pieces, Euler characteristic {} (expected one piece of Euler characteristic {expected}), signed volume {}",
                report.components, report.euler, report.signed_volume
            ),
        });
    }
    Ok(Shape {
        name,
        class,
        instance,
        mesh,
    })
}

/// `per_class` instances (numbered `0..per_class`) of each class in `classes`, class by
/// class, generated in parallel; the result does not depend on the number of threads.
/// `on_done` is called once per finished shape (for progress display), from any thread.
pub fn collection(
    classes: &[Class],
    per_class: usize,
    params: &GenerateParams,
    on_done: &(dyn Fn(&Shape) + Sync),
) -> Result<Vec<Shape>, ShapesError> {
    let jobs: Vec<(Class, usize)> = classes
        .iter()
        .flat_map(|&c| (0..per_class).map(move |i| (c, i)))
        .collect();
    jobs.par_iter()
        .map(|&(c, i)| {
            let s = generate(c, i, params)?;
            on_done(&s);
            Ok(s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> GenerateParams {
        GenerateParams {
            target_vertices: 4000,
            ..GenerateParams::default()
        }
    }

    #[test]
    fn every_class_is_a_valid_closed_surface_of_its_genus() {
        for class in Class::ALL {
            for i in 0..2 {
                let s = generate(class, i, &small()).expect("generates");
                let r = check::check_closed_manifold(&s.mesh).expect("closed manifold");
                assert_eq!(r.components, 1, "{}", s.name);
                assert_eq!(r.euler, 2 - 2 * class.genus(), "{}", s.name);
                assert!(r.signed_volume > 0.0, "{}", s.name);
                assert!(r.min_angle_deg > 0.5, "{}: {r:?}", s.name);
                assert!(r.min_relative_area > 1e-4, "{}: {r:?}", s.name);
                // welded: no two vertices at the same position
                let mut seen = std::collections::HashSet::new();
                for p in &s.mesh.positions {
                    assert!(
                        seen.insert([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]),
                        "{}: duplicate vertex at {p:?}",
                        s.name
                    );
                }
                let v = s.mesh.num_vertices() as f64;
                assert!((v / 4000.0 - 1.0).abs() < 0.3, "{}: {v} vertices", s.name);
            }
        }
    }

    #[test]
    fn generation_is_deterministic_and_thread_independent() {
        let a = generate(Class::Bird, 3, &small()).expect("a");
        let b = generate(Class::Bird, 3, &small()).expect("b");
        assert_eq!(a, b);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        let one = pool.install(|| collection(&[Class::Bird], 4, &small(), &|_| {}).expect("c"));
        let many = collection(&[Class::Bird], 4, &small(), &|_| {}).expect("c");
        assert_eq!(one, many);
        assert_eq!(one[3], a);
    }

    #[test]
    fn instances_and_seeds_differ() {
        let a = generate(Class::Fish, 0, &small()).expect("a");
        let b = generate(Class::Fish, 1, &small()).expect("b");
        assert_ne!(a.mesh.positions, b.mesh.positions);
        let other_seed = GenerateParams { seed: 7, ..small() };
        let c = generate(Class::Fish, 0, &other_seed).expect("c");
        assert_ne!(a.mesh.positions, c.mesh.positions);
    }

    /// Classes differ in shape, not only in pose: compare a rotation-invariant signature (the
    /// sorted eigenvalues of the vertex covariance, normalised by their sum) — instances of
    /// one class are closer to each other on average than to other classes.
    #[test]
    fn classes_differ_more_than_instances() {
        let shapes = collection(&Class::ALL, 4, &small(), &|_| {}).expect("collection");
        let sig = |m: &Mesh| {
            let n = m.num_vertices() as f64;
            let c = m.positions.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
            let mut cov = nalgebra::Matrix3::zeros();
            for p in &m.positions {
                let d = p.coords - c;
                cov += d * d.transpose();
            }
            let mut e: Vec<f64> = cov.symmetric_eigenvalues().iter().copied().collect();
            e.sort_by(|a, b| b.total_cmp(a));
            let s: f64 = e.iter().sum();
            e.iter().map(|x| x / s).collect::<Vec<f64>>()
        };
        let sigs: Vec<Vec<f64>> = shapes.iter().map(|s| sig(&s.mesh)).collect();
        let d = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt()
        };
        let (mut within, mut between) = ((0.0, 0), (0.0, 0));
        for i in 0..shapes.len() {
            for j in 0..i {
                let x = d(&sigs[i], &sigs[j]);
                if shapes[i].class == shapes[j].class {
                    within = (within.0 + x, within.1 + 1);
                } else {
                    between = (between.0 + x, between.1 + 1);
                }
            }
        }
        let (w, b) = (within.0 / within.1 as f64, between.0 / between.1 as f64);
        assert!(w < b, "mean distance within classes {w}, between {b}");
    }

    /// Generation is fast enough for the demo: one shape at the demo's 15k vertices (the
    /// slowest class, the octopus) in well under the few seconds the bound allows even on a
    /// loaded 2-core machine (about 0.3 s when quiet, release build).
    #[test]
    fn generation_time() {
        let params = GenerateParams {
            target_vertices: 15_000,
            ..GenerateParams::default()
        };
        let t = std::time::Instant::now();
        let s = generate(Class::Octopus, 0, &params).expect("generates");
        let secs = t.elapsed().as_secs_f64();
        assert!(s.mesh.num_vertices() > 12_000);
        assert!(secs < 5.0, "{secs} s for one shape");
    }

    #[test]
    fn class_names_round_trip_and_params_are_checked() {
        for c in Class::ALL {
            assert_eq!(Class::from_name(c.name()), Some(c));
        }
        let bad = GenerateParams {
            target_vertices: 10,
            ..GenerateParams::default()
        };
        assert!(matches!(
            generate(Class::Mug, 0, &bad),
            Err(ShapesError::Params(_))
        ));
    }
}
