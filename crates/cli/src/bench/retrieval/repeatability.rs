//! Partial repeatability (`--repeatability`): how well a fragment's own parts repeat the parts
//! of its source on the same surface, pooled by fragment kind and kept-area bin.

use std::path::Path;

use anyhow::Result;
use keycomp::{Profile, Role, analyse};
use serde::Serialize;

/// One row of the partial-repeatability table: the parts of every fragment of one kind and
/// kept-area bin pooled (see [`Repeatability`]).
#[derive(Debug, Serialize)]
pub(super) struct RepeatabilityRow {
    pub(super) kind: &'static str,
    pub(super) area: (f64, f64),
    pub(super) fragments: usize,
    pub(super) kc_parts: usize,
    pub(super) kc_overlap: f64,
    pub(super) patch_parts: usize,
    pub(super) patch_overlap: f64,
}

pub(super) fn repeatability_rows(
    all: &[(&'static str, f64, Repeatability)],
    range: (f64, f64),
) -> Vec<RepeatabilityRow> {
    let mut rows = Vec::new();
    let kinds: Vec<&'static str> = {
        let mut k: Vec<_> = all.iter().map(|r| r.0).collect();
        k.dedup();
        k
    };
    let step = (range.1 - range.0) / 3.0;
    for kind in kinds {
        for b in 0..3 {
            let lo = range.0 + step * b as f64;
            let hi = if b == 2 { f64::INFINITY } else { lo + step };
            let lo = if b == 0 { f64::NEG_INFINITY } else { lo };
            let sel: Vec<&Repeatability> = all
                .iter()
                .filter(|r| r.0 == kind && r.1 >= lo && r.1 < hi)
                .map(|r| &r.2)
                .collect();
            if sel.is_empty() {
                continue;
            }
            let kc_parts: usize = sel.iter().map(|r| r.kc_parts).sum();
            let patch_parts: usize = sel.iter().map(|r| r.patch_parts).sum();
            let pooled = |f: &dyn Fn(&Repeatability) -> f64, n: usize| {
                if n > 0 {
                    sel.iter().map(|r| f(r)).sum::<f64>() / n as f64
                } else {
                    0.0
                }
            };
            rows.push(RepeatabilityRow {
                kind,
                area: (range.0 + step * b as f64, range.0 + step * (b + 1) as f64),
                fragments: sel.len(),
                kc_parts,
                kc_overlap: pooled(&|r| r.kc_overlap * r.kc_parts as f64, kc_parts),
                patch_parts,
                patch_overlap: pooled(&|r| r.patch_overlap * r.patch_parts as f64, patch_parts),
            });
        }
    }
    rows
}

/// Partial repeatability of one fragment: for key-components (level 0) and for patches (levels
/// 1 to L, the whole surface left out), the source's parts with at least half of their area inside the fragment, and the
/// mean over them of the best overlap (area IoU on the fragment, as in the repeatability
/// benchmark) between the part restricted to the fragment and a part the fragment's own
/// analysis finds (of the same kind: key-component or patch, any level).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub(super) struct Repeatability {
    pub(super) kc_overlap: f64,
    pub(super) kc_parts: usize,
    pub(super) patch_overlap: f64,
    pub(super) patch_parts: usize,
}

pub(super) fn partial_repeatability(
    source: &Path,
    fragment: &Path,
    original: &[u32],
    profile: &Profile,
) -> Result<Repeatability> {
    let s = analyse(source, profile)?;
    let f = keycomp::analyse_as(fragment, profile, Role::Query)?;
    let src_areas = keycomp_mesh::geometry::vertex_areas(&s.mesh);
    let frag_areas = keycomp_mesh::geometry::vertex_areas(&f.mesh);
    let mut to_frag = vec![u32::MAX; s.mesh.num_vertices()];
    for (i, &o) in original.iter().enumerate() {
        if let Some(t) = to_frag.get_mut(o as usize) {
            *t = i as u32;
        }
    }
    // key-components are level 0, patches levels 1..=L; the whole surface (L + 1) is neither
    let whole = profile.describe.levels.len() + 1;
    let in_group = move |c: &&keycomp_describe::ComponentDescription, patches: bool| {
        (c.level as usize) < whole && (c.level > 0) == patches
    };
    let group = |patches: bool| -> (f64, usize) {
        let mine: Vec<&[u32]> = f
            .description
            .components
            .iter()
            .filter(|c| in_group(c, patches))
            .map(|c| c.vertices.as_slice())
            .collect();
        let (mut sum, mut count) = (0.0, 0);
        for c in s
            .description
            .components
            .iter()
            .filter(|c| in_group(c, patches))
        {
            let total: f64 = c.vertices.iter().map(|&v| src_areas[v as usize]).sum();
            let inside: Vec<u32> = c
                .vertices
                .iter()
                .map(|&v| to_frag[v as usize])
                .filter(|&t| t != u32::MAX)
                .collect();
            let kept: f64 = c
                .vertices
                .iter()
                .filter(|&&v| to_frag[v as usize] != u32::MAX)
                .map(|&v| src_areas[v as usize])
                .sum();
            if total <= 0.0 || kept < 0.5 * total {
                continue;
            }
            let best = mine
                .iter()
                .map(|m| keycomp_bench::overlap(&frag_areas, &inside, m))
                .fold(0.0, f64::max);
            sum += best;
            count += 1;
        }
        (if count > 0 { sum / count as f64 } else { 0.0 }, count)
    };
    let (kc_overlap, kc_parts) = group(false);
    let (patch_overlap, patch_parts) = group(true);
    Ok(Repeatability {
        kc_overlap,
        kc_parts,
        patch_overlap,
        patch_parts,
    })
}
