//! The component tree of a weighted graph, built with union-find.
//!
//! A graph `G = (V, E)` carries a *birth level* `b(v)` per vertex and a level `w(e)` per edge.
//! At a threshold `τ`, the graph `G_τ` has the vertices with `b(v) ≤ τ` and the edges with
//! `w(e) ≤ τ`; its connected components, over all `τ`, are nested (a component at `τ` lies in
//! one component at every `τ' > τ`), so they form a forest: the **component tree** (one tree per
//! connected piece of `G`). This covers both cases of Litman, Bronstein & Bronstein,
//! "Diffusion-geometric maximally stable component detection in deformable shapes", *Computers
//! & Graphics* 35(3):549–560, 2011 (Section 2):
//!
//! - **vertex-weighted** `f : V → ℝ` ([`ComponentTree::vertex_weighted`]): `b(v) = f(v)` and
//!   `w(u, v) = max(f(u), f(v))`, so `G_τ` is the subgraph induced by `{v : f(v) ≤ τ}` (the
//!   lower level set; the max-tree of `−f` in image-processing terms);
//! - **edge-weighted** `d : E → ℝ` ([`ComponentTree::edge_weighted`]): `G_τ = (V, {e : d(e) ≤
//!   τ})`. Single vertices are components of every `G_τ` but carry no information before their
//!   first edge joins them, so a vertex is born at the level of its lightest edge (a vertex
//!   without edges is not in the tree).
//!
//! # Algorithm
//!
//! Najman & Couprie's union-find construction ("Building the component tree in quasi-linear
//! time", *IEEE Trans. Image Processing* 15(11), 2006), for general graphs: sort the vertex
//! births and the edges by level (births first on ties, then by index, so the result is
//! deterministic) and sweep them upwards. A birth creates a node holding the vertex; an edge
//! whose ends lie in two different components (union-find with path halving and union by size)
//! joins them: if one of the two component nodes was created *at this very level*, the other
//! becomes its child (or both are fused when both were), otherwise a new node at the edge's
//! level gets both as children. So every node is a distinct vertex set, its level is the lowest
//! `τ` at which it is a component of `G_τ`, and a parent's level is strictly greater than its
//! children's. Each node also holds the vertices born into it directly ("own" vertices).
//!
//! Finally the vertices are laid out in depth-first order so that every node's vertex set is a
//! contiguous slice ([`ComponentTree::vertices`]) and containment of two nodes is a range test
//! ([`ComponentTree::contains`]).
//!
//! # Complexity
//!
//! `O((|V| + |E|) log(|V| + |E|))` for the sort, then `O((|V| + |E|) α(|V|))`; memory
//! `O(|V| + |E|)`. At most `2|V| − 1` nodes.

use keycomp_mesh::VertexId;

use crate::error::{MserError, Result};

const NONE: u32 = u32::MAX;

/// A component tree (forest) of a weighted graph (see the [module docs](self)). Nodes are
/// numbered `0..len()`; every node is a set of vertices with a level and an area (the sum of
/// its vertices' masses).
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentTree {
    level: Vec<f64>,
    area: Vec<f64>,
    parent: Vec<u32>,
    child_start: Vec<u32>,
    children: Vec<u32>,
    range: Vec<(u32, u32)>,
    order: Vec<VertexId>,
    node_of: Vec<u32>,
    roots: Vec<u32>,
}

struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> UnionFind {
        UnionFind {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }
    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = p;
        }
        x
    }
    /// Unites two roots; returns the new root.
    fn union(&mut self, a: u32, b: u32) -> u32 {
        let (big, small) = if self.size[a as usize] >= self.size[b as usize] {
            (a, b)
        } else {
            (b, a)
        };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
        big
    }
}

fn check_len(what: &'static str, found: usize, expected: usize) -> Result<()> {
    if found == expected {
        Ok(())
    } else {
        Err(MserError::LengthMismatch {
            what,
            found,
            expected,
        })
    }
}

impl ComponentTree {
    /// The component tree of the vertex-weighted graph with `weights` (one per vertex; `NaN`
    /// leaves the vertex out), vertex `masses` and undirected `edges` (see the
    /// [module docs](self)).
    ///
    /// Errors: slices of different lengths, an edge naming a vertex out of range, a negative
    /// or non-finite mass, or an infinite weight.
    pub fn vertex_weighted(
        weights: &[f64],
        masses: &[f64],
        edges: &[(VertexId, VertexId)],
    ) -> Result<ComponentTree> {
        check_len("masses", masses.len(), weights.len())?;
        let n = weights.len();
        let mut levelled = Vec::with_capacity(edges.len());
        for &(u, v) in edges {
            for x in [u, v] {
                if x as usize >= n {
                    return Err(MserError::VertexOutOfRange {
                        vertex: x,
                        vertices: n,
                    });
                }
            }
            let (a, b) = (weights[u as usize], weights[v as usize]);
            if a.is_nan() || b.is_nan() {
                continue;
            }
            levelled.push((u, v, a.max(b)));
        }
        Self::build(weights, masses, &levelled)
    }

    /// The component tree of the edge-weighted graph with `edges` `(u, v, level)` (edges with
    /// a `NaN` level are left out) and vertex `masses`; vertices are born at the level of their
    /// lightest edge (see the [module docs](self)).
    ///
    /// Errors: an edge naming a vertex out of range, a negative or non-finite mass, or an
    /// infinite level.
    pub fn edge_weighted(
        masses: &[f64],
        edges: &[(VertexId, VertexId, f64)],
    ) -> Result<ComponentTree> {
        let n = masses.len();
        let mut birth = vec![f64::NAN; n];
        let mut kept = Vec::with_capacity(edges.len());
        for (i, &(u, v, w)) in edges.iter().enumerate() {
            for x in [u, v] {
                if x as usize >= n {
                    return Err(MserError::VertexOutOfRange {
                        vertex: x,
                        vertices: n,
                    });
                }
            }
            if w.is_nan() {
                continue;
            }
            if w.is_infinite() {
                return Err(MserError::BadValue {
                    what: "edge weight",
                    index: i,
                    value: w,
                });
            }
            for x in [u, v] {
                let b = &mut birth[x as usize];
                // NaN.min(w) is w
                *b = b.min(w);
            }
            kept.push((u, v, w));
        }
        Self::build(&birth, masses, &kept)
    }

    /// The general construction: vertex births (`NaN`: not in the graph) and levelled edges
    /// whose levels are at least both ends' births (an edge below a birth is raised to it).
    fn build(
        birth: &[f64],
        masses: &[f64],
        edges: &[(VertexId, VertexId, f64)],
    ) -> Result<ComponentTree> {
        let n = birth.len();
        check_len("masses", masses.len(), n)?;
        if let Some(v) = masses.iter().position(|m| !(m.is_finite() && *m >= 0.0)) {
            return Err(MserError::BadValue {
                what: "vertex mass",
                index: v,
                value: masses[v],
            });
        }
        if let Some(v) = birth.iter().position(|b| b.is_infinite()) {
            return Err(MserError::BadValue {
                what: "vertex weight",
                index: v,
                value: birth[v],
            });
        }
        let mut events: Vec<(f64, u8, u32)> = Vec::with_capacity(n + edges.len());
        for (v, &b) in birth.iter().enumerate() {
            if !b.is_nan() {
                events.push((b, 0, v as u32));
            }
        }
        for (i, &(u, v, w)) in edges.iter().enumerate() {
            if w.is_infinite() {
                return Err(MserError::BadValue {
                    what: "edge weight",
                    index: i,
                    value: w,
                });
            }
            let (bu, bv) = (birth[u as usize], birth[v as usize]);
            if bu.is_nan() || bv.is_nan() || u == v {
                continue;
            }
            events.push((w.max(bu).max(bv), 1, i as u32));
        }
        events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));

        // construction nodes; `alias` forwards fused nodes
        let mut level: Vec<f64> = Vec::with_capacity(2 * n);
        let mut area: Vec<f64> = Vec::with_capacity(2 * n);
        let mut parent: Vec<u32> = Vec::with_capacity(2 * n);
        let mut alias: Vec<u32> = Vec::with_capacity(2 * n);
        let mut owner = vec![NONE; n];
        let mut comp_node = vec![NONE; n]; // per union-find root
        let mut uf = UnionFind::new(n);
        for &(lv, kind, idx) in &events {
            if kind == 0 {
                let node = level.len() as u32;
                level.push(lv);
                area.push(masses[idx as usize]);
                parent.push(NONE);
                alias.push(NONE);
                owner[idx as usize] = node;
                comp_node[idx as usize] = node;
                continue;
            }
            let (u, v, _) = edges[idx as usize];
            let (ru, rv) = (uf.find(u), uf.find(v));
            if ru == rv {
                continue;
            }
            let (a, b) = (comp_node[ru as usize], comp_node[rv as usize]);
            let (ai, bi) = (a as usize, b as usize);
            let (la, lb) = (level[ai] == lv, level[bi] == lv);
            let merged = if la && lb {
                // both were created at this level: fuse b into a (b is a root, so it has no
                // parent; its children and own vertices are forwarded through `alias`)
                alias[bi] = a;
                area[ai] += area[bi];
                a
            } else if la {
                parent[bi] = a;
                area[ai] += area[bi];
                a
            } else if lb {
                parent[ai] = b;
                area[bi] += area[ai];
                b
            } else {
                let c = level.len() as u32;
                level.push(lv);
                area.push(area[ai] + area[bi]);
                parent.push(NONE);
                alias.push(NONE);
                parent[ai] = c;
                parent[bi] = c;
                c
            };
            let r = uf.union(ru, rv);
            comp_node[r as usize] = merged;
        }
        let resolve = |mut x: u32, alias: &[u32]| {
            while alias[x as usize] != NONE {
                x = alias[x as usize];
            }
            x
        };
        // compact the live nodes
        let total = level.len();
        let mut new_id = vec![NONE; total];
        let mut count = 0u32;
        for (i, id) in new_id.iter_mut().enumerate() {
            if alias[i] == NONE {
                *id = count;
                count += 1;
            }
        }
        let m = count as usize;
        let mut t_level = vec![0.0; m];
        let mut t_area = vec![0.0; m];
        let mut t_parent = vec![NONE; m];
        for i in 0..total {
            if alias[i] != NONE {
                continue;
            }
            let id = new_id[i] as usize;
            t_level[id] = level[i];
            t_area[id] = area[i];
            if parent[i] != NONE {
                t_parent[id] = new_id[resolve(parent[i], &alias) as usize];
            }
        }
        let node_of: Vec<u32> = owner
            .iter()
            .map(|&o| {
                if o == NONE {
                    NONE
                } else {
                    new_id[resolve(o, &alias) as usize]
                }
            })
            .collect();

        // children in CSR form, ordered by node id
        let mut child_count = vec![0u32; m + 1];
        for &p in &t_parent {
            if p != NONE {
                child_count[p as usize + 1] += 1;
            }
        }
        for i in 0..m {
            child_count[i + 1] += child_count[i];
        }
        let child_start = child_count.clone();
        let mut fill = child_count;
        let mut children = vec![0u32; child_start[m] as usize];
        for (c, &p) in t_parent.iter().enumerate() {
            if p != NONE {
                children[fill[p as usize] as usize] = c as u32;
                fill[p as usize] += 1;
            }
        }
        // own vertices per node, CSR
        let mut own_start = vec![0u32; m + 1];
        for &o in &node_of {
            if o != NONE {
                own_start[o as usize + 1] += 1;
            }
        }
        for i in 0..m {
            own_start[i + 1] += own_start[i];
        }
        let mut own = vec![0 as VertexId; own_start[m] as usize];
        let mut fill = own_start.clone();
        for (v, &o) in node_of.iter().enumerate() {
            if o != NONE {
                own[fill[o as usize] as usize] = v as VertexId;
                fill[o as usize] += 1;
            }
        }
        // depth-first layout
        let roots: Vec<u32> = (0..m as u32)
            .filter(|&i| t_parent[i as usize] == NONE)
            .collect();
        let mut range = vec![(0u32, 0u32); m];
        let mut order: Vec<VertexId> = Vec::with_capacity(own.len());
        let mut stack: Vec<(u32, bool)> = Vec::new();
        for &r in &roots {
            stack.push((r, false));
            while let Some((x, done)) = stack.pop() {
                let xi = x as usize;
                if done {
                    range[xi].1 = order.len() as u32;
                    continue;
                }
                range[xi].0 = order.len() as u32;
                order.extend_from_slice(&own[own_start[xi] as usize..own_start[xi + 1] as usize]);
                stack.push((x, true));
                let kids = &children[child_start[xi] as usize..child_start[xi + 1] as usize];
                for &c in kids.iter().rev() {
                    stack.push((c, false));
                }
            }
        }
        Ok(ComponentTree {
            level: t_level,
            area: t_area,
            parent: t_parent,
            child_start,
            children,
            range,
            order,
            node_of,
            roots,
        })
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.level.len()
    }

    /// Whether the tree has no node (a graph without vertices).
    pub fn is_empty(&self) -> bool {
        self.level.is_empty()
    }

    /// The level of node `i`: the lowest threshold at which it is a component. Panics if
    /// `i ≥ len()`.
    pub fn level(&self, i: usize) -> f64 {
        self.level[i]
    }

    /// The area of node `i`: the sum of its vertices' masses.
    pub fn area(&self, i: usize) -> f64 {
        self.area[i]
    }

    /// The parent of node `i` (the smallest strictly larger component), `None` for a root.
    pub fn parent(&self, i: usize) -> Option<usize> {
        let p = self.parent[i];
        (p != NONE).then_some(p as usize)
    }

    /// The children of node `i`, in increasing id order.
    pub fn children(&self, i: usize) -> &[u32] {
        &self.children[self.child_start[i] as usize..self.child_start[i + 1] as usize]
    }

    /// The roots: one per connected piece of the graph, in increasing id order.
    pub fn roots(&self) -> &[u32] {
        &self.roots
    }

    /// The vertices of node `i` (depth-first order, not sorted).
    pub fn vertices(&self, i: usize) -> &[VertexId] {
        let (a, b) = self.range[i];
        &self.order[a as usize..b as usize]
    }

    /// The vertices of node `i`, sorted.
    pub fn sorted_vertices(&self, i: usize) -> Vec<VertexId> {
        let mut v = self.vertices(i).to_vec();
        v.sort_unstable();
        v
    }

    /// Whether node `a` contains node `b` (every vertex of `b` is in `a`; true for `a == b`).
    pub fn contains(&self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.range[a], self.range[b]);
        ra.0 <= rb.0 && rb.1 <= ra.1
    }

    /// The smallest node containing vertex `v` (the node it was born into), `None` if `v` is
    /// not in the graph or out of range.
    pub fn node_of(&self, v: VertexId) -> Option<usize> {
        match self.node_of.get(v as usize) {
            Some(&n) if n != NONE => Some(n as usize),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sets(t: &ComponentTree) -> Vec<(f64, f64, Vec<VertexId>)> {
        (0..t.len())
            .map(|i| (t.level(i), t.area(i), t.sorted_vertices(i)))
            .collect()
    }

    #[test]
    fn vertex_weighted_path_with_two_valleys() {
        // path 0-1-2-3-4, f = [0, 2, 4, 1, 3]: level sets {0} | {0},{3} | {0,1},{3} |
        // {0,1},{3,4} | everything
        let f = [0.0, 2.0, 4.0, 1.0, 3.0];
        let m = [1.0; 5];
        let e = [(0, 1), (1, 2), (2, 3), (3, 4)];
        let t = ComponentTree::vertex_weighted(&f, &m, &e).unwrap();
        let mut got = sets(&t);
        got.sort_by(|a, b| a.0.total_cmp(&b.0));
        let want = vec![
            (0.0, 1.0, vec![0]),
            (1.0, 1.0, vec![3]),
            (2.0, 2.0, vec![0, 1]),
            (3.0, 2.0, vec![3, 4]),
            (4.0, 5.0, vec![0, 1, 2, 3, 4]),
        ];
        assert_eq!(got, want);
        assert_eq!(t.roots().len(), 1);
        let root = t.roots()[0] as usize;
        assert_eq!(t.children(root).len(), 2);
        let leaf0 = t.node_of(0).unwrap();
        let n01 = t.parent(leaf0).unwrap();
        assert_eq!(t.sorted_vertices(n01), vec![0, 1]);
        assert_eq!(t.parent(n01), Some(root));
        assert!(t.contains(root, leaf0) && !t.contains(leaf0, root));
        assert_eq!(t.node_of(2), Some(root));
        assert_eq!(t.node_of(9), None);
    }

    #[test]
    fn edge_weighted_two_pairs_fuse_at_equal_levels() {
        // 0-1 and 2-3 at level 1, joined at level 5 (by two edges)
        let m = [1.0, 2.0, 3.0, 4.0];
        let e = [(0, 1, 1.0), (2, 3, 1.0), (1, 2, 5.0), (0, 3, 5.0)];
        let t = ComponentTree::edge_weighted(&m, &e).unwrap();
        let mut got = sets(&t);
        got.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
        assert_eq!(
            got,
            vec![
                (1.0, 3.0, vec![0, 1]),
                (1.0, 7.0, vec![2, 3]),
                (5.0, 10.0, vec![0, 1, 2, 3]),
            ]
        );
        // a chain of equal edges is one node, not a cascade
        let chain =
            ComponentTree::edge_weighted(&[1.0; 4], &[(0, 1, 2.0), (1, 2, 2.0), (2, 3, 2.0)])
                .unwrap();
        assert_eq!(chain.len(), 1);
        assert_eq!(chain.sorted_vertices(0), vec![0, 1, 2, 3]);
        // an isolated vertex (no edge) is not in the tree; NaN edges are left out
        let t = ComponentTree::edge_weighted(&[1.0; 3], &[(0, 1, 0.5), (1, 2, f64::NAN)]).unwrap();
        assert_eq!(t.len(), 1);
        assert_eq!(t.node_of(2), None);
    }

    #[test]
    fn two_pieces_give_two_roots_and_bad_input_is_rejected() {
        let f = [0.0, 1.0, 0.5, 0.2];
        let t = ComponentTree::vertex_weighted(&f, &[1.0; 4], &[(0, 1), (2, 3)]).unwrap();
        assert_eq!(t.roots().len(), 2);
        let e = ComponentTree::vertex_weighted(&f, &[1.0; 3], &[]).unwrap_err();
        assert!(matches!(e, MserError::LengthMismatch { .. }), "{e}");
        let e = ComponentTree::vertex_weighted(&f, &[1.0; 4], &[(0, 7)]).unwrap_err();
        assert!(e.to_string().contains("vertex 7"), "{e}");
        let e = ComponentTree::vertex_weighted(&f, &[1.0, -1.0, 1.0, 1.0], &[]).unwrap_err();
        assert!(e.to_string().contains("mass"), "{e}");
        let e = ComponentTree::edge_weighted(&[1.0; 2], &[(0, 1, f64::INFINITY)]).unwrap_err();
        assert!(e.to_string().contains("edge weight"), "{e}");
        assert!(
            ComponentTree::vertex_weighted(&[], &[], &[])
                .unwrap()
                .is_empty()
        );
    }
}
