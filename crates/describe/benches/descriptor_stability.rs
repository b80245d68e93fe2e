//! How far apart corresponding key-components are in descriptor space, compared with
//! non-corresponding ones, under the repeatability benchmark's transformations.
//!
//! For each null shape (TOSCA cat0, centaur0, dog0, KIDS 0001.null.0) and each transformation
//! kind at strength 3 (seed 0), KC-1 components of the null and transformed shapes are described;
//! each transformed component is carried to the null shape (`keycomp_bench::Pullback`) and paired
//! with every null component: area IoU > 0.5 = corresponding, IoU < 0.05 = not corresponding.
//! Prints the median descriptor distance of both groups per kind, as a markdown table.
//!
//! `cargo bench -p keycomp-describe --bench descriptor_stability -- [DATA_DIR [SMOOTHING]]`
//! (DATA_DIR: default `../shared/data`, a relative path taken from the workspace root;
//! SMOOTHING: Taubin λ|μ pairs before describing, default 30 as in `DescribeParams`).

use keycomp_bench::{Kind, Pullback, overlap, transform};
use keycomp_components::{DetectParams, detect};
use keycomp_describe::{DescribeParams, describe_with, distance};
use keycomp_mesh::{Topology, geometry, read_mesh};
use keycomp_test_support::{SHARED_DATA, bench_args, median, workspace_path};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = bench_args("cargo bench -p keycomp-describe --bench descriptor_stability")
    else {
        return Ok(());
    };
    // relative to the workspace root (`cargo bench` runs a bench in its crate's folder)
    let data = workspace_path(args.get(1).map_or(SHARED_DATA, String::as_str));
    let nulls = [
        "tosca/cat0.off",
        "tosca/centaur0.off",
        "tosca/dog0.off",
        "kids/0001.null.0.off",
    ];
    let describe_params = DescribeParams {
        smoothing_iterations: match args.get(2) {
            Some(s) => s.parse()?,
            None => DescribeParams::default().smoothing_iterations,
        },
        ..DescribeParams::default()
    };
    let describe = |m: &keycomp_mesh::Mesh, d: &keycomp_components::Detection| {
        describe_with(m, d, &describe_params)
    };
    let params = DetectParams::default();
    let mut rows: Vec<(String, Vec<f32>, Vec<f32>)> = Kind::ALL
        .iter()
        .map(|k| (k.to_string(), Vec::new(), Vec::new()))
        .collect();
    for name in nulls {
        let path = data.join(name);
        let null = match read_mesh(&path) {
            Ok(m) => m.mesh,
            Err(e) => {
                eprintln!("skipping {name}: {e}");
                continue;
            }
        };
        let topo = Topology::new(&null);
        let areas = geometry::vertex_areas(&null);
        let dn = detect(&null, &params)?;
        let descn = describe(&null, &dn)?;
        for (ki, kind) in Kind::ALL.iter().enumerate() {
            let Ok(t) = transform(&null, *kind, 3, 0) else {
                eprintln!("{name}: {kind} does not apply");
                continue;
            };
            let dt = detect(&t.mesh, &params)?;
            let desct = describe(&t.mesh, &dt)?;
            let pull = Pullback::new(&null, &topo, &t.map)?;
            for (ct, c) in dt.components.iter().enumerate() {
                let carried = pull.carry(&c.vertices);
                for (cn, n) in dn.components.iter().enumerate() {
                    let iou = overlap(&areas, &carried, &n.vertices);
                    let d = distance(
                        &desct.components[ct].descriptor,
                        &descn.components[cn].descriptor,
                    );
                    if iou > 0.5 {
                        rows[ki].1.push(d);
                    } else if iou < 0.05 {
                        rows[ki].2.push(d);
                    }
                }
            }
            eprintln!("{name}: {kind} done");
        }
    }
    println!(
        "| transformation (strength 3) | corresponding: n, median distance | non-corresponding: n, median distance |"
    );
    println!("|---|---:|---:|");
    let fmt = |v: &Vec<f32>| {
        if v.is_empty() {
            "0, –".to_string()
        } else {
            let m = median(v.iter().copied().map(f64::from).collect());
            format!("{}, {m:.3}", v.len())
        }
    };
    let (mut all_c, mut all_n) = (Vec::new(), Vec::new());
    for (kind, c, n) in &rows {
        println!("| {kind} | {} | {} |", fmt(c), fmt(n));
        all_c.extend(c);
        all_n.extend(n);
    }
    println!("| all | {} | {} |", fmt(&all_c), fmt(&all_n));
    Ok(())
}
