use std::sync::atomic::{AtomicUsize, Ordering};

use keycomp_components::{ClusterParams, GeodesicOptions, Preset, SmacofParams};
use keycomp_harris::{HarrisParams, Selection};
use keycomp_mesh::geometry::vertex_areas;
use keycomp_mesh::{Topology, VertexId, synth, write_off};
use keycomp_mser::{Method, MserParams};
use keycomp_surface::SurfaceParams;

use super::config::{fraction_count, referenced};
use super::discover::stem;
use super::score::per_strength_table;
use super::shape::{Job, LoadedNull, Source};
use super::*;
use crate::cache::EmbeddingCache;
use crate::error::BenchError;
use crate::evaluate::{Record, mean_overlap_table};
use crate::staged::embed;
use crate::transform::Kind;

/// The paper's presets with N = 8, so the small test shape has components.
fn presets() -> Vec<PresetSpec> {
    Preset::ALL
        .iter()
        .map(|p| {
            let c = p.component_params();
            PresetSpec {
                name: format!("{p}*"),
                method: Method::Kc,
                cluster: ClusterParams {
                    n_min: 8,
                    ..c.cluster
                },
                sigma: c.sigma,
                sphere: c.sphere,
                grouping: c.grouping,
                paper_name: p.to_string(),
            }
        })
        .collect()
}

fn config(kinds: Vec<Kind>, strengths: Vec<u8>, cache: Option<EmbeddingCache>) -> Config {
    Config {
        presets: presets(),
        harris: HarrisParams::default(),
        budget: Budget::PerShape(Selection::Fraction(0.01)),
        smacof: SmacofParams::default(),
        geodesic: GeodesicOptions::default(),
        mser: MserParams::default(),
        kinds,
        isometry: true,
        strengths,
        seed: 3,
        cache,
        parallel_shapes: true,
        surface: None,
        remeshed: None,
        retessellation: false,
        remeshed_isometry: false,
    }
}

/// The re-tessellation rows read their copies from the remeshed folder, mapped by nearest
/// vertex; a copy that is the shape itself repeats everything exactly (overlaps 1, every
/// keypoint and cluster in place), a rotated pose too. A missing folder is a skip with its
/// reason, not an error.
#[test]
fn remeshed_copies_are_read_and_mapped_by_nearest_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let tosca = dir.path().join("data/tosca");
    std::fs::create_dir_all(&tosca).unwrap();
    let mesh = synth::textured_protrusion_sphere(5);
    write_off(&mesh, &tosca.join("blob0.off")).unwrap();
    // a pose: the same vertices turned a quarter about z
    let turned = keycomp_mesh::Mesh {
        positions: mesh
            .positions
            .iter()
            .map(|p| keycomp_mesh::Point3::new(-p.y, p.x, p.z))
            .collect(),
        faces: mesh.faces.clone(),
    };
    write_off(&turned, &tosca.join("blob1.off")).unwrap();
    let remeshed = dir.path().join("remeshed");
    for s in 1..=5 {
        let d = remeshed.join(format!("s{s}/tosca"));
        std::fs::create_dir_all(&d).unwrap();
        write_off(&mesh, &d.join("blob0.off")).unwrap();
        write_off(&turned, &d.join("blob1.off")).unwrap();
    }
    let nulls = discover(&dir.path().join("data")).unwrap();
    let cfg = Config {
        remeshed: Some(remeshed),
        retessellation: true,
        remeshed_isometry: true,
        isometry: false,
        ..config(Vec::new(), vec![1, 3], None)
    };
    let (report, _) = run(&cfg, &nulls, &|_| {}).unwrap();
    assert!(report.skipped.is_empty(), "{:?}", report.skipped);
    let kinds: Vec<&str> = report.shapes.iter().map(|s| s.kind.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "null",
            "isometry-remeshed",
            "retessellation",
            "retessellation"
        ]
    );
    for pr in &report.presets[..2] {
        for row in &pr.stages {
            assert_eq!(row.keypoints, Some(1.0), "{} {}", pr.preset.name, row.kind);
            assert_eq!(row.clusters, Some(1.0), "{} {}", pr.preset.name, row.kind);
            assert_eq!(row.components, Some(1.0), "{} {}", pr.preset.name, row.kind);
        }
        // the extra rows stay out of the average, which has none of the paper's rows here:
        // then every row counts
        assert_eq!(pr.mean_overlap.average[0], Some(1.0));
    }
    assert!(report.shapes[2].source.ends_with("s1/tosca/blob0.off"));
    // without the folder's copies: skipped, with the script to run
    let empty = Config {
        remeshed: Some(dir.path().join("nowhere")),
        ..cfg
    };
    let (report, _) = run(&empty, &nulls, &|_| {}).unwrap();
    assert_eq!(report.skipped.len(), 3);
    assert!(report.skipped[0].reason.contains("retessellate.py"));
}

#[test]
fn discovers_the_shared_layout_and_flat_folders() {
    let dir = tempfile::tempdir().unwrap();
    let tosca = dir.path().join("tosca");
    let kids = dir.path().join("kids");
    std::fs::create_dir_all(&tosca).unwrap();
    std::fs::create_dir_all(&kids).unwrap();
    for f in [
        "cat0.off",
        "cat1.off",
        "cat10.off",
        "cat2.off",
        "cat3.off",
        "cat4.off",
        "cat5.off",
        "cat6.off",
        "wolf0.off",
        "wolf2.off",
        "lion3.off",
        "notes.txt",
    ] {
        std::fs::write(tosca.join(f), "").unwrap();
    }
    for f in [
        "0001.null.0.off",
        "0001.isometry.2.off",
        "0001.isometry.1.off",
    ] {
        std::fs::write(kids.join(f), "").unwrap();
    }
    let faust = dir.path().join("faust");
    std::fs::create_dir_all(&faust).unwrap();
    for f in [
        "tr_reg_000.ply",
        "tr_reg_001.ply",
        "tr_reg_003.ply",
        "tr_reg_010.ply",
    ] {
        std::fs::write(faust.join(f), "").unwrap();
    }
    let nulls = discover(dir.path()).unwrap();
    let names: Vec<&str> = nulls.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["cat0", "wolf0", "kids-0001", "faust-000"]);
    let fp: Vec<u8> = nulls[3].poses.iter().map(|p| p.strength).collect();
    assert_eq!(
        fp,
        [1, 3],
        "subject 0's poses 1 and 3; tr_reg_010 is subject 1"
    );
    let cat: Vec<(u8, String)> = nulls[0]
        .poses
        .iter()
        .map(|p| (p.strength, stem(&p.path)))
        .collect();
    // numeric order, at most five
    assert_eq!(
        cat,
        [
            (1, "cat1"),
            (2, "cat2"),
            (3, "cat3"),
            (4, "cat4"),
            (5, "cat5")
        ]
        .map(|(s, n)| (s, n.to_owned()))
    );
    assert_eq!(nulls[1].poses.len(), 1);
    assert_eq!(nulls[1].poses[0].strength, 1);
    assert_eq!(nulls[2].poses.len(), 2);
    assert_eq!(stem(&nulls[2].poses[1].path), "0001.isometry.2");

    // a flat folder: every mesh is a null shape
    let flat = dir.path().join("flat");
    std::fs::create_dir_all(&flat).unwrap();
    std::fs::write(flat.join("b.off"), "").unwrap();
    std::fs::write(flat.join("a.ply"), "").unwrap();
    std::fs::write(flat.join("readme.md"), "").unwrap();
    let nulls = discover(&flat).unwrap();
    assert_eq!(
        nulls.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(),
        ["a", "b"]
    );
    assert!(nulls.iter().all(|n| n.poses.is_empty()));

    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let e = discover(&empty).unwrap_err().to_string();
    assert!(e.contains("empty") && e.contains("no null shape"), "{e}");
    let e = discover(&dir.path().join("missing"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing") && e.contains("no such folder"), "{e}");
}

#[test]
fn fraction_budgets_resolve_to_the_same_keypoints_as_harris() {
    let mesh = synth::textured_protrusion_sphere(4);
    let f = HarrisParams::default();
    let cfg = config(vec![], vec![1], None);
    let resolved = HarrisParams {
        selection: cfg.selection_for(&mesh, 0),
        ..f
    };
    assert!(matches!(resolved.selection, Selection::Count(_)));
    let s = SmacofParams::default();
    assert_eq!(
        embed(&mesh, &f, &s, &cfg.geodesic).unwrap(),
        embed(&mesh, &resolved, &s, &cfg.geodesic).unwrap()
    );
    let calibrated = Config {
        budget: Budget::NullCalibrated(0.01),
        ..cfg
    };
    assert_eq!(
        calibrated.selection_for(&mesh, 12_345),
        Selection::Count(123)
    );
    assert_eq!(fraction_count(0.01, 10), 1);
}

#[test]
fn canonical_surfaces_carry_components_back_to_the_shapes_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = synth::textured_protrusion_sphere(5);
    write_off(&mesh, &dir.path().join("proto.off")).unwrap();
    let nulls = discover(dir.path()).unwrap();
    let robust = Preset::Robust.component_params();
    let salient = PresetSpec {
        name: "robust".into(),
        method: Method::Kc,
        cluster: robust.cluster,
        sigma: robust.sigma,
        sphere: robust.sphere,
        grouping: robust.grouping,
        paper_name: "robust".into(),
    };
    let cfg = Config {
        surface: Some(SurfaceParams {
            vertices: 3000,
            ..SurfaceParams::default()
        }),
        presets: vec![salient],
        ..config(vec![Kind::Scale], vec![1], None)
    };
    let (report, _) = run(&cfg, &nulls, &|_| {}).unwrap();
    assert!(report.skipped.is_empty(), "{:?}", report.skipped);
    assert_eq!(report.surface, cfg.surface);
    // the salient grouping finds components on the sphere's canonical surface and again on
    // its scaled copy's (the surface is made in a frame of unit area: the same, scaled)
    let pr = &report.presets[0];
    let scale = pr.mean_overlap.rows[0].values[0].unwrap();
    assert!(scale > 0.99, "{}: {scale}", pr.preset.name);
    let n = mesh.num_vertices() as VertexId;
    for s in &report.shapes {
        assert!(s.presets[0].components > 0, "{} has no component", s.kind);
        assert_eq!(
            s.vertices,
            mesh.num_vertices(),
            "counts are the shape's own"
        );
    }
    // the carried components are sets of the null shape's vertices
    let outcome = cfg
        .run_job(
            &Job {
                null: 0,
                source: Source::Null,
            },
            &[LoadedNull {
                spec: nulls[0].clone(),
                topo: Topology::new(&mesh),
                areas: vertex_areas(&mesh),
                referenced: referenced(&mesh),
                mesh: mesh.clone(),
            }],
        )
        .unwrap();
    let c = &outcome.components[0][0];
    assert!(!c.is_empty() && c.windows(2).all(|w| w[0] < w[1]) && c[c.len() - 1] < n);
}

#[test]
fn scale_repeats_perfectly_and_the_cache_reproduces_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    write_off(
        &synth::textured_protrusion_sphere(5),
        &data.join("proto.off"),
    )
    .unwrap();
    let nulls = discover(&data).unwrap();
    let cache = EmbeddingCache::new(dir.path().join("cache"));
    let cfg = config(vec![Kind::Scale, Kind::Noise], vec![1, 2], Some(cache));
    let calls = AtomicUsize::new(0);
    let count = |p: Progress<'_>| {
        assert_eq!(p.total, 5);
        calls.fetch_add(1, Ordering::Relaxed);
    };
    let (report, stats) = run(&cfg, &nulls, &count).unwrap();
    assert_eq!(calls.load(Ordering::Relaxed), 5);
    assert_eq!(stats.computed, 5);
    assert_eq!(report.shapes.len(), 5);
    assert!(report.skipped.is_empty(), "{:?}", report.skipped);
    for pr in &report.presets {
        // rows in the paper's order: scale before noise
        let scale = &pr.mean_overlap.rows[0];
        assert_eq!(scale.kind, "scale");
        // scale invariance: the same components, exactly
        let v = scale.values[1].unwrap();
        assert!(v > 0.999, "{}: {v}", pr.preset.name);
        assert_eq!(pr.curves.len(), 2);
        assert_eq!(pr.curves[0].values.len(), report.thresholds.len());
        assert_eq!(pr.curves[0].values[0], 1.0);
    }
    assert_eq!(report.presets[0].paper.unwrap().preset, "KC-1");
    // second run: everything from the cache, identical report
    let (again, stats) = run(&cfg, &nulls, &|_| {}).unwrap();
    assert_eq!(stats.cache_hits, 5);
    assert_eq!(stats.computed, 0);
    assert_eq!(again, report);
    // sequential gives the same report
    let seq = Config {
        parallel_shapes: false,
        cache: None,
        ..cfg
    };
    assert_eq!(run(&seq, &nulls, &|_| {}).unwrap().0, report);
    let md = report.markdown();
    assert!(md.contains("| Scale | 1.00 / 0.95"), "{md}");
    assert!(md.contains("| Average |"), "{md}");
}

#[test]
fn mser_methods_run_beside_key_components_and_are_cached() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    write_off(&synth::protrusion_sphere(4, 0.8, 0.25), &data.join("p.off")).unwrap();
    let nulls = discover(&data).unwrap();
    let cache = EmbeddingCache::new(dir.path().join("cache"));
    let mut cfg = config(vec![Kind::Scale], vec![1], Some(cache));
    cfg.presets = [Method::Mser, Method::MserKc]
        .into_iter()
        .filter_map(PresetSpec::mser)
        .collect();
    let (report, stats) = run(&cfg, &nulls, &|_| {}).unwrap();
    assert!(report.skipped.is_empty(), "{:?}", report.skipped);
    assert_eq!(stats.computed, 2);
    let null = &report.shapes[0];
    assert_eq!(null.kind, "null");
    // six protrusions: six HKS keypoints, at least six MSER components, and the covering
    // set is one component per protrusion
    assert_eq!(null.keypoints, 6);
    assert!(null.presets[0].components >= 6, "{null:?}");
    assert_eq!(null.presets[1].components, 6, "{null:?}");
    for pr in &report.presets {
        let v = pr.mean_overlap.rows[0].values[0].unwrap();
        assert!(v > 0.99, "{}: scale overlap {v}", pr.preset.name);
    }
    assert_eq!(
        report.presets[0].paper.unwrap().source,
        "Sipiran & Bustos 2013, Table 5"
    );
    assert_eq!(
        report.presets[1].paper.unwrap().source,
        "Sipiran & Bustos 2013, Table 6"
    );
    let md = report.markdown();
    assert!(md.contains("### MSER-KC (edge weights"), "{md}");
    // second run from the cache: same report
    let (again, stats) = run(&cfg, &nulls, &|_| {}).unwrap();
    assert_eq!(stats.cache_hits, 2);
    assert_eq!(again, report);
}

#[test]
fn per_strength_table_does_not_pool() {
    let rec = |kind: &str, strength, b: Vec<f64>| Record {
        kind: kind.into(),
        strength,
        best_overlaps: b,
    };
    let records = vec![
        rec("sampling", 1, vec![0.6, 0.8]),
        rec("sampling", 2, vec![0.1]),
        rec("noise", 1, vec![1.0]),
    ];
    let cumulative = mean_overlap_table(&records);
    let t = per_strength_table(&records, &cumulative);
    assert_eq!(t.rows[0].kind, "sampling");
    assert!((t.rows[0].values[0].unwrap() - 0.7).abs() < 1e-12);
    assert!((t.rows[0].values[1].unwrap() - 0.1).abs() < 1e-12);
    assert_eq!(t.rows[0].values[2], None);
    // pooled ≤ 2 is (0.6 + 0.8 + 0.1) / 3
    assert!((cumulative.rows[0].values[1].unwrap() - 0.5).abs() < 1e-12);
    assert!((t.average[0].unwrap() - 0.85).abs() < 1e-12);
    assert!((t.average[1].unwrap() - 0.1).abs() < 1e-12);
}

#[test]
fn inapplicable_transformations_are_skipped_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    write_off(&synth::icosphere(3, 1.0), &dir.path().join("ball.off")).unwrap();
    let nulls = discover(dir.path()).unwrap();
    let cfg = config(vec![Kind::Topology], vec![1], None);
    let (report, _) = run(&cfg, &nulls, &|_| {}).unwrap();
    assert_eq!(report.skipped.len(), 1);
    assert_eq!(report.skipped[0].kind, "topology");
    assert!(
        report.skipped[0].reason.contains("weld"),
        "{:?}",
        report.skipped
    );
    let bad = Config {
        strengths: vec![6],
        ..cfg
    };
    assert!(matches!(
        run(&bad, &nulls, &|_| {}),
        Err(BenchError::InvalidStrength { strength: 6 })
    ));
}
