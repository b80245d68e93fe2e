//! Describing a large mesh on a simplified proxy ([`DescribeParams::proxy_vertices`]): the
//! proxy detection's fast-marching fronts ran on (`keycomp_components::Proxy`, half-edge
//! collapses with the keypoints protected, every survivor at its input position), or the same
//! simplification made here when the detection did not keep one. Description's cost is linear
//! in the vertices it runs on (the smoothing, a Harris fit per vertex, the geodesic solver and
//! one front per part centre), so a fixed budget bounds it on meshes of any size, and both
//! stages share one simplification.
//!
//! The parts are chosen and described on the proxy, then lifted back to the input's vertex ids:
//! a centre is a survivor, so it keeps its id; a patch holds the input vertices whose nearest
//! survivor along the mesh's edges (`keycomp_mesh::graph::dijkstra`) is in the patch; a key-component
//! keeps its own vertices, and the whole surface all of them.

use std::sync::Arc;

use keycomp_components::{Detection, GeodesicOptions, KeyComponent, Proxy, geodesic_proxy};
use keycomp_mesh::graph::dijkstra;
use keycomp_mesh::{Mesh, Topology, VertexId, geometry};

use crate::params::DescribeParams;

/// A mesh's proxy with the detection carried onto it, and the way back.
pub(crate) struct OnProxy {
    /// The proxy's faces on the input's positions (file units).
    pub(crate) mesh: Mesh,
    /// The detection in the proxy's vertex ids.
    pub(crate) det: Detection,
    proxy: Arc<Proxy>,
    /// Input vertices, grouped by the survivor that stands for them (`members[start[p]..start[p
    /// + 1]]` for proxy vertex p).
    start: Vec<u32>,
    members: Vec<u32>,
    /// The input's vertices, and how many lie on its boundary.
    pub(crate) n: usize,
    pub(crate) boundary_vertices: usize,
}

/// The proxy `mesh` is described on under `params`, if it has more vertices than the budget:
/// the detection's own when it was simplified to the same budget in the same cells, else a new
/// one made the same way (so the description does not depend on which it was).
pub(crate) fn on_proxy(mesh: &Mesh, det: &Detection, params: &DescribeParams) -> Option<OnProxy> {
    if params.proxy_vertices == 0 || mesh.num_vertices() <= params.proxy_vertices {
        return None;
    }
    let options = GeodesicOptions {
        proxy_vertices: params.proxy_vertices,
        proxy_cell_vertices: GeodesicOptions::DEFAULT_PROXY_CELL_VERTICES,
        ..GeodesicOptions::default()
    };
    let topo = Topology::new(mesh);
    let referenced = (0..mesh.num_vertices() as VertexId)
        .filter(|&v| !topo.faces_of(v).is_empty())
        .count();
    let proxy = match &det.proxy {
        Some(p)
            if p.target == options.proxy_vertices && p.cells == options.proxy_cells(referenced) =>
        {
            p.clone()
        }
        _ => {
            let (norm, _) = geometry::normalize_unit_area(mesh);
            Arc::new(geodesic_proxy(&norm, &topo, &det.keypoints, &options)?)
        }
    };
    let s = &proxy.simplified;
    let map = |v: VertexId| s.proxy_vertex(v);
    let components: Option<Vec<KeyComponent>> = det
        .components
        .iter()
        .map(|c| {
            Some(KeyComponent {
                id: c.id,
                center: map(c.center)?,
                sphere_center: c.sphere_center,
                sphere_radius: c.sphere_radius,
                keypoints: c.keypoints.iter().filter_map(|&k| map(k)).collect(),
                vertices: c.vertices.iter().filter_map(|&v| map(v)).collect(),
                // faces are not read by description
                faces: Vec::new(),
                area: c.area,
                missed_keypoints: Vec::new(),
            })
        })
        .collect();
    let det_on = Detection {
        area: det.area,
        scale: det.scale,
        embedding: det.embedding.clone(),
        disconnected_pairs: det.disconnected_pairs,
        geodesic_vertices: det.geodesic_vertices,
        timings: det.timings,
        response: s
            .original
            .iter()
            .map(|&v| det.response.get(v as usize).copied().unwrap_or(f64::NAN))
            .collect(),
        keypoints: det
            .keypoints
            .iter()
            .map(|&k| map(k))
            .collect::<Option<_>>()?,
        unclustered: det.unclustered.iter().filter_map(|&k| map(k)).collect(),
        components: components?,
        proxy: None,
    };
    let owner = nearest_survivor(mesh, &topo, &s.original);
    let (start, members) = group(&owner, s.original.len());
    Some(OnProxy {
        mesh: Mesh {
            positions: s
                .original
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect(),
            faces: s.mesh.faces.clone(),
        },
        det: det_on,
        proxy,
        start,
        members,
        n: mesh.num_vertices(),
        boundary_vertices: topo.boundary_vertices().len(),
    })
}

impl OnProxy {
    /// The input vertex that proxy vertex `v` is.
    pub(crate) fn input_vertex(&self, v: u32) -> u32 {
        self.proxy.simplified.original[v as usize]
    }

    /// The input vertices the proxy vertices `part` stand for, in increasing order.
    pub(crate) fn input_vertices(&self, part: &[u32]) -> Vec<u32> {
        let mut vs: Vec<u32> = part
            .iter()
            .flat_map(|&p| {
                let (a, b) = (self.start[p as usize], self.start[p as usize + 1]);
                self.members[a as usize..b as usize].iter().copied()
            })
            .collect();
        vs.sort_unstable();
        vs
    }
}

/// For every vertex of `mesh`, the index into `survivors` (vertex ids) of the one nearest along
/// the mesh's edges (ties: the lower index; `keycomp_mesh::graph::dijkstra`); `u32::MAX` for
/// vertices no survivor reaches (unreferenced ones, pieces the simplification dropped).
fn nearest_survivor(mesh: &Mesh, topo: &Topology, survivors: &[VertexId]) -> Vec<u32> {
    let mut owner = vec![u32::MAX; mesh.num_vertices()];
    let sources: Vec<(VertexId, u32)> = (0..).zip(survivors).map(|(i, &v)| (v, i)).collect();
    dijkstra(
        &mesh.positions,
        topo,
        &sources,
        f64::INFINITY,
        |v, _, label| {
            owner[v as usize] = label;
            true
        },
    );
    owner
}

/// The vertices of each of `groups` owners, in increasing order, as offsets and members.
fn group(owner: &[u32], groups: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; groups + 1];
    for &o in owner {
        if (o as usize) < groups {
            start[o as usize + 1] += 1;
        }
    }
    for i in 0..groups {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut members = vec![0u32; start[groups] as usize];
    for (v, &o) in owner.iter().enumerate() {
        if (o as usize) < groups {
            members[next[o as usize] as usize] = v as u32;
            next[o as usize] += 1;
        }
    }
    (start, members)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_vertex_goes_to_its_nearest_survivor_along_edges() {
        // a path 0-1-2-3-4 of unit edges (as thin triangles), survivors 0 and 4
        let mesh = Mesh {
            positions: (0..5)
                .map(|i| keycomp_mesh::Point3::new(i as f64, 0.0, 0.0))
                .chain((0..5).map(|i| keycomp_mesh::Point3::new(i as f64 + 0.5, 10.0, 0.0)))
                .collect(),
            faces: (0..4u32)
                .flat_map(|i| [[i, i + 1, i + 5], [i + 1, i + 6, i + 5]])
                .collect(),
        };
        let topo = Topology::new(&mesh);
        let owner = nearest_survivor(&mesh, &topo, &[0, 4]);
        assert_eq!(&owner[..5], &[0, 0, 0, 1, 1]);
        let (start, members) = group(&owner, 2);
        assert_eq!(start[2] as usize, 10);
        assert!(members[..start[1] as usize].contains(&2));
        assert!(members[start[1] as usize..].contains(&3));
    }
}
