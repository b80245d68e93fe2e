//! Keypoint selection (step 6): local maxima of the response, then a budget or a spacing rule.

use keycomp_mesh::{Mesh, Topology, VertexId};

use keycomp_mesh::geometry::total_area;

use crate::params::{Selection, UnitArea};
use crate::size::moment_diagonal;

/// Candidates: vertices with a (finite) response that is ≥ the response of every 1-ring
/// neighbour that has one (ties count, so two equal neighbours are both candidates; NaN
/// neighbours impose nothing). Returned best first: response descending, ties by vertex id
/// ascending. O(|E| + c log c) for c candidates.
///
/// Vertices beyond `topo`'s or `response`'s length are ignored.
pub fn local_maxima(topo: &Topology, response: &[f64]) -> Vec<VertexId> {
    let n = response.len().min(topo.num_vertices());
    let mut c: Vec<VertexId> = (0..n as VertexId)
        .filter(|&v| {
            let r = response[v as usize];
            r.is_finite()
                && topo.neighbors(v).iter().all(|&w| {
                    response
                        .get(w as usize)
                        .is_none_or(|&rw| rw <= r || rw.is_nan())
                })
        })
        .collect();
    c.sort_by(|&a, &b| {
        response[b as usize]
            .total_cmp(&response[a as usize])
            .then(a.cmp(&b))
    });
    c
}

/// Chooses keypoints among the [`local_maxima`] of `response`; best first.
///
/// Meant for a validated [`Selection`] (see [`Selection::validate`]); other values never panic:
/// a fraction or count that rounds below 1 gives one keypoint, one above the candidates gives
/// all of them, and a negative or NaN spacing is no spacing.
pub fn select_keypoints(
    mesh: &Mesh,
    topo: &Topology,
    response: &[f64],
    selection: &Selection,
) -> Vec<VertexId> {
    select_keypoints_in(mesh, topo, response, selection, UnitArea::Own)
}

/// [`select_keypoints`] with [`Selection::PerArea`] budgets measured against `unit` (the area
/// that counts as 1) instead of the mesh's own area.
pub fn select_keypoints_in(
    mesh: &Mesh,
    topo: &Topology,
    response: &[f64],
    selection: &Selection,
    unit: UnitArea,
) -> Vec<VertexId> {
    let mut cands = local_maxima(topo, response);
    match *selection {
        Selection::PerArea(density) => {
            let area = total_area(mesh) / unit.area(mesh);
            // `as` saturates (NaN → 0), then at least 1
            let budget = ((density * area).round() as usize).max(1);
            cands.truncate(budget);
            cands
        }
        Selection::Fraction(f) => {
            let referenced = (0..topo.num_vertices() as VertexId)
                .filter(|&v| !topo.faces_of(v).is_empty())
                .count();
            // `as` saturates (NaN → 0), then at least 1
            let budget = ((f * referenced as f64).round() as usize).max(1);
            cands.truncate(budget);
            cands
        }
        Selection::Count(n) => {
            cands.truncate(n.max(1));
            cands
        }
        Selection::Spacing {
            fraction_of_diagonal,
            max,
        } => {
            let max = max.unwrap_or(usize::MAX).max(1);
            let d = fraction_of_diagonal * moment_diagonal(mesh);
            let d2 = if d.is_finite() && d > 0.0 { d * d } else { 0.0 };
            let mut chosen: Vec<VertexId> = Vec::new();
            for v in cands {
                if chosen.len() >= max {
                    break;
                }
                let Some(p) = mesh.positions.get(v as usize) else {
                    continue;
                };
                let far = chosen
                    .iter()
                    .all(|&c| (mesh.positions[c as usize] - p).norm_squared() >= d2);
                if far {
                    chosen.push(v);
                }
            }
            chosen
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    #[test]
    fn ties_count_and_order_is_deterministic() {
        let m = synth::grid(2, 2, 1.0); // 3 × 3 vertices
        let t = Topology::new(&m);
        // equal maxima at vertices 4 (centre) and 2, NaN at 0
        let mut r = vec![0.0; 9];
        r[0] = f64::NAN;
        r[4] = 5.0;
        r[2] = 5.0;
        let c = local_maxima(&t, &r);
        assert_eq!(&c[..2], &[2, 4], "ties by id");
        // NaN vertex never a candidate; vertex 1 is below 4
        assert!(!c.contains(&0) && !c.contains(&1));
        assert_eq!(select_keypoints(&m, &t, &r, &Selection::Count(1)), vec![2]);
        assert_eq!(
            select_keypoints(&m, &t, &r, &Selection::Count(100)).len(),
            c.len()
        );
        // fraction rounds to nearest with a floor of 1
        assert_eq!(
            select_keypoints(&m, &t, &r, &Selection::Fraction(0.01)),
            vec![2]
        );
        assert_eq!(
            select_keypoints(&m, &t, &r, &Selection::Fraction(f64::NAN)),
            vec![2]
        );
        // all equal: every vertex is a local maximum
        let flat = vec![1.0; 9];
        assert_eq!(local_maxima(&t, &flat), (0..9).collect::<Vec<_>>());
        // spacing beyond the whole diagonal leaves one keypoint
        let sp = Selection::Spacing {
            fraction_of_diagonal: 1.5,
            max: None,
        };
        assert_eq!(select_keypoints(&m, &t, &flat, &sp), vec![0]);
        let sp = Selection::Spacing {
            fraction_of_diagonal: 0.0,
            max: Some(4),
        };
        assert_eq!(select_keypoints(&m, &t, &flat, &sp), vec![0, 1, 2, 3]);
    }

    /// A per-area budget is the density times the area in the unit's frame: its own area
    /// counts as 1, a given unit area scales it, and it is capped by the candidates.
    #[test]
    fn per_area_budget_follows_the_area_in_the_unit() {
        let m = synth::grid(10, 10, 0.1); // 11 × 11 vertices, area 1
        let t = Topology::new(&m);
        let flat = vec![1.0; m.num_vertices()]; // every vertex a candidate
        let pick = |density: f64, unit: UnitArea| {
            select_keypoints_in(&m, &t, &flat, &Selection::PerArea(density), unit).len()
        };
        assert_eq!(pick(40.0, UnitArea::Own), 40);
        // the grid taken for a quarter of a shape four times its area
        assert_eq!(pick(40.0, UnitArea::Given(4.0)), 10);
        assert_eq!(pick(40.0, UnitArea::Given(0.5)), 80);
        // never fewer than one, never more than the candidates
        assert_eq!(pick(0.1, UnitArea::Own), 1);
        assert_eq!(pick(1e5, UnitArea::Own), m.num_vertices());
        assert_eq!(pick(40.0, UnitArea::Given(f64::NAN)), 1);
        assert_eq!(
            select_keypoints(&m, &t, &flat, &Selection::PerArea(40.0)).len(),
            40
        );
        // the same surface sampled four times as densely gets the same budget
        let fine = synth::grid(20, 20, 0.05);
        let tf = Topology::new(&fine);
        let flat = vec![1.0; fine.num_vertices()];
        assert_eq!(
            select_keypoints(&fine, &tf, &flat, &Selection::PerArea(40.0)).len(),
            40
        );
    }
}
