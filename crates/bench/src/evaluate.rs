//! Component overlap and repeatability (Sipiran & Bustos, "Key-components: detection of salient
//! regions on 3D meshes", The Visual Computer 29(12), 2013, Section 4.2, after Litman et al.,
//! "Diffusion-geometric maximally stable component detection in deformable shapes", Computers
//! & Graphics 35(3), 2011).
//!
//! Components are vertex sets. Areas are measured on the null shape X with barycentric vertex
//! areas ([`keycomp_mesh::geometry::vertex_areas`]): A(S) = Σ_{v ∈ S} a_v. The overlap (Eq. 4) is
//! `O(X_i, X'_j) = A(X_i ∩ X'_j) / A(X_i ∪ X'_j)`, where X'_j is the component Y_j of the
//! transformed shape Y carried to X through the ground-truth correspondence.
//!
//! **Carrying a component.** The correspondence maps transformed vertices to null vertices but
//! is not onto for `sampling` and `holes` (many null vertices have no preimage), so the image
//! {map(y) : y ∈ Y_j} of a perfectly repeated region would be a sparse subset of it and score
//! far below 1. [`Pullback`] therefore labels *every* null vertex v with the transformed vertex
//! whose image is nearest to v along the null surface: a multi-source Dijkstra over the null
//! edges (Euclidean lengths) from all images at once, ties to the smaller transformed id; a null
//! vertex with several preimages is labelled with the smallest. The carried component is
//! `X'_j = { v ∈ X : label(v) ∈ Y_j }`: the union of the Voronoi cells (on X) of Y_j's images.
//! For a one-to-one map every vertex is its own source, the labelling is the inverse map and
//! carrying is exact, so a repeated component scores exactly 1. For a decimated or holed shape
//! the cells tile X, and if Y_j is exactly the set of transformed vertices whose images lie in
//! X_i, its cells cover X_i up to a band of half a cell along the boundary of X_i (and holes
//! inside X_i are filled from the nearest surviving vertices), so the overlap is ≈ 1 minus the
//! boundary band's share of the area. Null vertices on a piece of X with no image at all stay
//! unlabelled and are never carried.
//!
//! **Repeatability at overlap o** is the fraction of transformed components whose best overlap
//! max_i O(X_i, X'_j) is strictly greater than o; with no components it is 0 (nothing was
//! repeated). Tables in the paper's Table 1 layout pool the best overlaps of all records of a
//! transformation with strength ≤ s ([`cumulative_table`]).
//!
//! Complexity: [`Pullback::new`] O(|V_X| log |V_X|); [`Pullback::carry`] O(k log k) for k carried
//! vertices; [`overlap`] O(|a| log |a| + |b| log |b|); [`best_overlaps`] O(Σ|X_i| + Σ|X'_j|·m) with
//! m the number of null components sharing a vertex (1 for a partition).

use keycomp_mesh::{Mesh, Topology, VertexId};
use serde::{Deserialize, Serialize};

use crate::error::BenchError;
use crate::graph::dijkstra;
use crate::transform::MAX_STRENGTH;

/// The dense labelling of a null shape by transformed vertices, built once per transformed
/// shape and used to carry any number of its components (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct Pullback {
    /// For each null vertex, the transformed vertex it is carried from (`u32::MAX`: none).
    label: Vec<u32>,
    /// Null vertices labelled with each transformed vertex, in CSR form.
    offsets: Vec<u32>,
    cells: Vec<VertexId>,
}

const NONE: u32 = u32::MAX;

impl Pullback {
    /// Builds the labelling from the null mesh, its topology and the correspondence
    /// `map[transformed vertex] = Some(null vertex)`.
    ///
    /// Errors: [`BenchError::MapOutOfRange`] if an entry is not a null vertex.
    pub fn new(
        null: &Mesh,
        topology: &Topology,
        map: &[Option<VertexId>],
    ) -> Result<Pullback, BenchError> {
        let n = null.num_vertices();
        let mut first = vec![NONE; n];
        for (t, m) in map.iter().enumerate() {
            if let Some(v) = *m {
                let slot = first.get_mut(v as usize).ok_or(BenchError::MapOutOfRange {
                    index: t,
                    target: v,
                    null_vertices: n,
                })?;
                if *slot == NONE {
                    *slot = t as u32;
                }
            }
        }
        let sources: Vec<(VertexId, u32)> = first
            .iter()
            .enumerate()
            .filter(|(_, t)| **t != NONE)
            .map(|(v, &t)| (v as VertexId, t))
            .collect();
        let mut label = vec![NONE; n];
        dijkstra(
            &null.positions,
            topology,
            &sources,
            f64::INFINITY,
            |v, _, t| {
                label[v as usize] = t;
                true
            },
        );
        Ok(Pullback::from_labels(label, map.len()))
    }

    /// Labels every vertex of `shape` with its nearest vertex of `canonical` in space: carries
    /// components found on a shape's canonical surface (`--surface canonical`) back to the
    /// shape's vertices, which the surface lies on (a canonical component becomes the union
    /// of its vertices' Voronoi cells among the shape's vertices). A canonical surface without
    /// vertices labels nothing.
    pub fn nearest(shape: &Mesh, canonical: &Mesh) -> Pullback {
        let label = keycomp_surface::nearest_vertices(&shape.positions, &canonical.positions)
            .unwrap_or_else(|| vec![NONE; shape.num_vertices()]);
        Pullback::from_labels(label, canonical.num_vertices())
    }

    /// The CSR cells of `label` (each vertex's source among `sources` vertices, [`NONE`] for
    /// none).
    fn from_labels(label: Vec<u32>, sources: usize) -> Pullback {
        let mut offsets = vec![0u32; sources + 1];
        for &t in &label {
            if t != NONE {
                offsets[t as usize + 1] += 1;
            }
        }
        for i in 0..sources {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut cells = vec![0; offsets[sources] as usize];
        for (v, &t) in label.iter().enumerate() {
            if t != NONE {
                cells[fill[t as usize] as usize] = v as VertexId;
                fill[t as usize] += 1;
            }
        }
        Pullback {
            label,
            offsets,
            cells,
        }
    }

    /// The transformed vertex that null vertex `v` is carried from (`None` if `v` is on a piece
    /// of the null shape without any image, or out of range).
    pub fn label(&self, v: VertexId) -> Option<VertexId> {
        self.label.get(v as usize).copied().filter(|&t| t != NONE)
    }

    /// Number of transformed vertices the map covers.
    pub fn num_transformed(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The null vertices carried from the transformed vertices `component` (any order,
    /// duplicates allowed; ids out of range are ignored): sorted, without duplicates.
    pub fn carry(&self, component: &[VertexId]) -> Vec<VertexId> {
        let mut out = Vec::new();
        let mut ids = component.to_vec();
        ids.sort_unstable();
        ids.dedup();
        for t in ids {
            let t = t as usize;
            if t + 1 < self.offsets.len() {
                out.extend_from_slice(
                    &self.cells[self.offsets[t] as usize..self.offsets[t + 1] as usize],
                );
            }
        }
        out.sort_unstable();
        out
    }
}

/// Sorted, deduplicated copy.
fn set(v: &[VertexId]) -> Vec<VertexId> {
    let mut s = v.to_vec();
    s.sort_unstable();
    s.dedup();
    s
}

fn area_of(areas: &[f64], s: &[VertexId]) -> f64 {
    s.iter()
        .map(|&v| areas.get(v as usize).copied().unwrap_or(0.0))
        .sum()
}

/// The overlap (Eq. 4) `A(a ∩ b) / A(a ∪ b)` of two vertex sets of the null shape, with
/// `areas` the null shape's barycentric vertex areas. Lists may be unsorted and contain
/// duplicates; ids without an area count 0. Two sets of zero union area overlap 0.
pub fn overlap(areas: &[f64], a: &[VertexId], b: &[VertexId]) -> f64 {
    let (a, b) = (set(a), set(b));
    let (mut i, mut j, mut inter) = (0, 0, 0.0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                inter += areas.get(a[i] as usize).copied().unwrap_or(0.0);
                i += 1;
                j += 1;
            }
        }
    }
    let union = area_of(areas, &a) + area_of(areas, &b) - inter;
    if union > 0.0 {
        (inter / union).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// For each carried transformed component, its best overlap with any null component (0 when
/// there are no null components or none intersects it). Components are null-vertex lists as in
/// [`overlap`].
pub fn best_overlaps(
    null_components: &[Vec<VertexId>],
    carried_components: &[Vec<VertexId>],
    areas: &[f64],
) -> Vec<f64> {
    let n = areas.len();
    // vertex -> null components containing it (CSR), and each null component's area
    let null_sets: Vec<Vec<VertexId>> = null_components
        .iter()
        .map(|c| set(c).into_iter().filter(|&v| (v as usize) < n).collect())
        .collect();
    let null_area: Vec<f64> = null_sets.iter().map(|s| area_of(areas, s)).collect();
    let mut offsets = vec![0usize; n + 1];
    for s in &null_sets {
        for &v in s {
            offsets[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut owners = vec![0u32; offsets[n]];
    for (i, s) in null_sets.iter().enumerate() {
        for &v in s {
            owners[fill[v as usize]] = i as u32;
            fill[v as usize] += 1;
        }
    }
    let mut inter = vec![0.0; null_sets.len()];
    let mut touched: Vec<u32> = Vec::new();
    carried_components
        .iter()
        .map(|c| {
            let s: Vec<VertexId> = set(c).into_iter().filter(|&v| (v as usize) < n).collect();
            let a_y = area_of(areas, &s);
            for &v in &s {
                for &i in &owners[offsets[v as usize]..offsets[v as usize + 1]] {
                    if inter[i as usize] == 0.0 {
                        touched.push(i);
                    }
                    inter[i as usize] += areas[v as usize];
                }
            }
            let mut best: f64 = 0.0;
            for &i in &touched {
                let x = inter[i as usize];
                let union = null_area[i as usize] + a_y - x;
                if union > 0.0 {
                    best = best.max((x / union).clamp(0.0, 1.0));
                }
                inter[i as usize] = 0.0;
            }
            touched.clear();
            best
        })
        .collect()
}

/// The vertices of the null shape (`positions`, `topology`) within `radius` of any of
/// `sources` along its edges (multi-source Dijkstra over Euclidean edge lengths, an upper bound
/// of the geodesic distance), sorted.
pub fn within(
    positions: &[keycomp_mesh::Point3<f64>],
    topology: &Topology,
    sources: &[VertexId],
    radius: f64,
) -> Vec<VertexId> {
    let seeds: Vec<(VertexId, u32)> = sources.iter().map(|&v| (v, 0)).collect();
    let mut out = Vec::new();
    dijkstra(positions, topology, &seeds, radius, |v, _, _| {
        out.push(v);
        true
    });
    out.sort_unstable();
    out.dedup();
    out
}

/// The share of `points` (null vertices, e.g. a transformed shape's keypoints carried to the
/// null shape) that lie in `near` (sorted null vertices, e.g. [`within`] a radius of the null
/// shape's keypoints); `None` for no points.
pub fn share_within(near: &[VertexId], points: &[VertexId]) -> Option<f64> {
    (!points.is_empty()).then(|| {
        let hits = points
            .iter()
            .filter(|v| near.binary_search(v).is_ok())
            .count();
        hits as f64 / points.len() as f64
    })
}

/// Repeatability at overlap `o`: the fraction of transformed components whose best overlap is
/// strictly greater than `o`; 0 when there are no components.
pub fn repeatability(best_overlaps: &[f64], o: f64) -> f64 {
    if best_overlaps.is_empty() {
        return 0.0;
    }
    best_overlaps.iter().filter(|&&b| b > o).count() as f64 / best_overlaps.len() as f64
}

/// [`repeatability`] at each overlap threshold in `thresholds` (the curves of Figs. 7–9).
pub fn repeatability_curve(best_overlaps: &[f64], thresholds: &[f64]) -> Vec<f64> {
    thresholds
        .iter()
        .map(|&o| repeatability(best_overlaps, o))
        .collect()
}

/// The best overlaps of the components of one transformed shape (or several shapes of the same
/// transformation and strength). `kind` is free text so real-data transformations such as
/// `isometry` fit next to the generated [`crate::Kind`]s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Transformation name (a row of the table).
    pub kind: String,
    /// Strength 1..=5; other values are ignored by the tables.
    pub strength: u8,
    /// Best overlap of each transformed component ([`best_overlaps`]).
    pub best_overlaps: Vec<f64>,
}

/// A row of a [`CumulativeTable`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableRow {
    /// Transformation name.
    pub kind: String,
    /// Value for strengths ≤ 1, ≤ 2, …, ≤ 5 (`None`: no component to measure).
    pub values: Vec<Option<f64>>,
}

/// A table in the layout of the paper's Table 1: one row per transformation (in order of first
/// appearance in the records), one column per cumulative strength ≤ 1 … ≤ 5, and an average row
/// ([`average_row`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CumulativeTable {
    /// One row per transformation.
    pub rows: Vec<TableRow>,
    /// Per column, the mean of the rows' values that are present (`None` if none is).
    pub average: Vec<Option<f64>>,
}

/// Builds a [`CumulativeTable`]: cell (kind, s) is `stat` of the best overlaps of all records of
/// that kind with strength ≤ s, pooled; the average row is the mean over rows per column.
pub fn cumulative_table(
    records: &[Record],
    stat: impl Fn(&[f64]) -> Option<f64>,
) -> CumulativeTable {
    let mut kinds: Vec<&str> = Vec::new();
    for r in records {
        if !kinds.contains(&r.kind.as_str()) {
            kinds.push(&r.kind);
        }
    }
    let columns = usize::from(MAX_STRENGTH);
    let rows: Vec<TableRow> = kinds
        .iter()
        .map(|&k| {
            let values = (1..=MAX_STRENGTH)
                .map(|s| {
                    let pooled: Vec<f64> = records
                        .iter()
                        .filter(|r| r.kind == k && (1..=s).contains(&r.strength))
                        .flat_map(|r| r.best_overlaps.iter().copied())
                        .collect();
                    stat(&pooled)
                })
                .collect();
            TableRow {
                kind: k.to_owned(),
                values,
            }
        })
        .collect();
    let average = average_row(&rows, columns);
    CumulativeTable { rows, average }
}

/// Per column, the mean of the values present in the rows that count in the average
/// ([`crate::paper::in_average`]: the paper's rows, or every row when there is none of them).
pub fn average_row(rows: &[TableRow], columns: usize) -> Vec<Option<f64>> {
    let paper = rows.iter().any(|r| crate::paper::in_average(&r.kind));
    (0..columns)
        .map(|c| {
            let present: Vec<f64> = rows
                .iter()
                .filter(|r| !paper || crate::paper::in_average(&r.kind))
                .filter_map(|r| r.values.get(c).copied().flatten())
                .collect();
            (!present.is_empty()).then(|| present.iter().sum::<f64>() / present.len() as f64)
        })
        .collect()
}

/// The paper's Table 1: average best overlap per transformation and cumulative strength
/// (`None` where no component was detected).
pub fn mean_overlap_table(records: &[Record]) -> CumulativeTable {
    cumulative_table(records, |b| {
        (!b.is_empty()).then(|| b.iter().sum::<f64>() / b.len() as f64)
    })
}

/// Repeatability at overlap `o` per transformation and cumulative strength (`None` where no
/// component was detected, rather than [`repeatability`]'s 0, so empty cells stay visible).
pub fn repeatability_table(records: &[Record], o: f64) -> CumulativeTable {
    cumulative_table(records, |b| (!b.is_empty()).then(|| repeatability(b, o)))
}

#[cfg(test)]
mod tests;
