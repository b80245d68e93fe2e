//! Property tests of the component tree and the stable-component selection against a brute
//! force: every node is exactly a connected component of the thresholded graph at its level,
//! every such component is a node, the nodes nest, areas add up and grow towards the root, and
//! the selected components are local minima of the variation within the requested bounds.

use std::collections::BTreeSet;

use keycomp_mesh::VertexId;
use keycomp_mser::{ComponentTree, StableParams, maximally_stable, variations};
use proptest::prelude::*;

/// The components of the graph with the vertices born at or below `tau` and the edges at or
/// below `tau` (BFS over an adjacency list).
fn components_at(
    birth: &[f64],
    edges: &[(VertexId, VertexId, f64)],
    tau: f64,
) -> BTreeSet<Vec<VertexId>> {
    let n = birth.len();
    let mut adj = vec![Vec::new(); n];
    for &(u, v, w) in edges {
        if w <= tau && birth[u as usize] <= tau && birth[v as usize] <= tau {
            adj[u as usize].push(v);
            adj[v as usize].push(u);
        }
    }
    let mut seen = vec![false; n];
    let mut out = BTreeSet::new();
    for s in 0..n {
        // NaN births (not in the graph) fail `<=`
        if seen[s] || birth[s].is_nan() || birth[s] > tau {
            continue;
        }
        let mut comp = vec![s as VertexId];
        seen[s] = true;
        let mut i = 0;
        while i < comp.len() {
            for &w in &adj[comp[i] as usize] {
                if !seen[w as usize] {
                    seen[w as usize] = true;
                    comp.push(w);
                }
            }
            i += 1;
        }
        comp.sort_unstable();
        out.insert(comp);
    }
    out
}

/// Checks the tree against the brute force for births and levelled edges.
fn check(tree: &ComponentTree, birth: &[f64], edges: &[(VertexId, VertexId, f64)], masses: &[f64]) {
    let mut levels: Vec<f64> = birth.iter().copied().filter(|b| !b.is_nan()).collect();
    levels.extend(edges.iter().map(|e| e.2));
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let mut all = BTreeSet::new();
    for &tau in &levels {
        all.extend(components_at(birth, edges, tau));
    }
    let nodes: BTreeSet<Vec<VertexId>> = (0..tree.len()).map(|i| tree.sorted_vertices(i)).collect();
    assert_eq!(nodes.len(), tree.len(), "nodes are distinct sets");
    assert_eq!(nodes, all, "nodes = components of all thresholded graphs");
    for i in 0..tree.len() {
        let verts = tree.sorted_vertices(i);
        // a node is a component of the graph at its own level
        assert!(components_at(birth, edges, tree.level(i)).contains(&verts));
        let mass: f64 = verts.iter().map(|&v| masses[v as usize]).sum();
        assert!((mass - tree.area(i)).abs() <= 1e-9 * (1.0 + mass));
        if let Some(p) = tree.parent(i) {
            assert!(tree.level(p) > tree.level(i), "levels increase to the root");
            assert!(tree.area(p) >= tree.area(i));
            assert!(tree.contains(p, i));
            let pv = tree.sorted_vertices(p);
            assert!(verts.iter().all(|v| pv.binary_search(v).is_ok()), "nesting");
        }
        // children are disjoint
        let kids = tree.children(i);
        for (a, &x) in kids.iter().enumerate() {
            for &y in &kids[a + 1..] {
                let (x, y) = (
                    tree.sorted_vertices(x as usize),
                    tree.sorted_vertices(y as usize),
                );
                assert!(x.iter().all(|v| y.binary_search(v).is_err()));
            }
        }
    }
    // the roots partition the vertices in the graph
    let mut count = vec![0; birth.len()];
    for &r in tree.roots() {
        for &v in tree.vertices(r as usize) {
            count[v as usize] += 1;
        }
    }
    for (v, &c) in count.iter().enumerate() {
        assert_eq!(c, usize::from(tree.node_of(v as VertexId).is_some()));
    }
}

/// Vertex count, edges (possibly loops and repeats), weights, masses.
type Graph = (usize, Vec<(VertexId, VertexId)>, Vec<f64>, Vec<f64>);

fn graph() -> impl Strategy<Value = Graph> {
    (1usize..14).prop_flat_map(|n| {
        let n32 = n as VertexId;
        (
            Just(n),
            prop::collection::vec((0..n32, 0..n32), 0..3 * n),
            // few distinct levels, so ties and fusions happen
            prop::collection::vec((0u8..6).prop_map(f64::from), n),
            prop::collection::vec(0.1f64..5.0, n),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn vertex_weighted_tree_matches_brute_force((_n, edges, f, masses) in graph()) {
        let tree = ComponentTree::vertex_weighted(&f, &masses, &edges).unwrap();
        let levelled: Vec<(VertexId, VertexId, f64)> = edges
            .iter()
            .filter(|(u, v)| u != v)
            .map(|&(u, v)| (u, v, f[u as usize].max(f[v as usize])))
            .collect();
        check(&tree, &f, &levelled, &masses);
        // a vertex is born into a node of its own weight
        for (v, &w) in f.iter().enumerate() {
            let node = tree.node_of(v as VertexId).unwrap();
            prop_assert_eq!(tree.level(node), w);
        }
    }

    #[test]
    fn edge_weighted_tree_matches_brute_force(
        (n, edges, w, masses) in graph(),
    ) {
        let levelled: Vec<(VertexId, VertexId, f64)> = edges
            .iter()
            .enumerate()
            .filter(|(_, (u, v))| u != v)
            .map(|(i, &(u, v))| (u, v, w[i % n]))
            .collect();
        let tree = ComponentTree::edge_weighted(&masses, &levelled).unwrap();
        let mut birth = vec![f64::NAN; n];
        for &(u, v, l) in &levelled {
            for x in [u, v] {
                birth[x as usize] = birth[x as usize].min(l);
            }
        }
        check(&tree, &birth, &levelled, &masses);
    }

    #[test]
    fn stable_components_are_bounded_local_minima(
        (_n, edges, f, masses) in graph(),
        delta in 0.5f64..3.0,
        min_area in 0.0f64..0.3,
        span in 0.0f64..0.7,
        min_diversity in 0.0f64..0.9,
    ) {
        let tree = ComponentTree::vertex_weighted(&f, &masses, &edges).unwrap();
        let params = StableParams {
            delta,
            min_area,
            max_area: min_area + span,
            max_variation: f64::INFINITY,
            min_diversity,
        };
        let got = maximally_stable(&tree, &params).unwrap();
        let var = variations(&tree, delta);
        let total: f64 = tree.roots().iter().map(|&r| tree.area(r as usize)).sum();
        for s in &got {
            prop_assert!(s.area >= min_area && s.area <= min_area + span);
            prop_assert!((s.area - tree.area(s.node) / total).abs() < 1e-12);
            prop_assert_eq!(s.variation, var[s.node]);
            if let Some(p) = tree.parent(s.node) {
                prop_assert!(var[s.node] < var[p]);
            }
            for &c in tree.children(s.node) {
                prop_assert!(var[s.node] <= var[c as usize]);
            }
        }
        // most stable first, no two nested near-duplicates
        for (i, a) in got.iter().enumerate() {
            for b in &got[i + 1..] {
                prop_assert!(a.variation <= b.variation);
                let nested = tree.contains(a.node, b.node) || tree.contains(b.node, a.node);
                if nested {
                    let (big, small) = if a.area >= b.area { (a.area, b.area) } else { (b.area, a.area) };
                    prop_assert!((big - small) / big >= min_diversity);
                }
            }
        }
    }
}
