//! Vertex colours for the PLY outputs: a colour map for scalar fields and a palette of distinct
//! colours for key-components.

use keycomp_components::Detection;
use keycomp_mesh::{Mesh, Topology, VertexId};

/// Neutral grey for vertices that belong to nothing.
pub const GREY: [u8; 3] = [170, 170, 170];

/// Colour of highlighted keypoints.
pub const KEYPOINT: [u8; 3] = [255, 0, 200];

/// A perceptually ordered map from t ∈ [0, 1] to colour (dark blue → teal → yellow), piecewise
/// linear between five stops close to matplotlib's "viridis".
pub fn colormap(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mut c = [0u8; 3];
    for k in 0..3 {
        c[k] = (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8;
    }
    c
}

/// Colours a per-vertex scalar field by rank (the field's quantile), which shows heavy-tailed
/// fields such as the Harris response evenly. Non-finite values are grey.
pub fn by_rank(values: &[f64]) -> Vec<[u8; 3]> {
    let mut order: Vec<usize> = (0..values.len())
        .filter(|&i| values[i].is_finite())
        .collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut colors = vec![GREY; values.len()];
    let denom = order.len().saturating_sub(1).max(1) as f64;
    for (rank, &i) in order.iter().enumerate() {
        colors[i] = colormap(rank as f64 / denom);
    }
    colors
}

/// Paints each keypoint and its 1-ring in the keypoint colour so it is visible in a viewer.
pub fn highlight(colors: &mut [[u8; 3]], topo: &Topology, keypoints: &[VertexId]) {
    for &k in keypoints {
        colors[k as usize] = KEYPOINT;
        for &w in topo.neighbors(k) {
            colors[w as usize] = KEYPOINT;
        }
    }
}

/// The i-th of a sequence of distinct, saturated colours (golden-angle hue steps).
pub fn distinct(i: usize) -> [u8; 3] {
    let h = (i as f64 * 137.507_764) % 360.0;
    let (s, v) = (0.75, if i.is_multiple_of(2) { 0.95 } else { 0.75 });
    hsv(h, s, v)
}

fn hsv(h: f64, s: f64, v: f64) -> [u8; 3] {
    let c = v * s;
    let x = c * (1.0 - ((h / 60.0) % 2.0 - 1.0).abs());
    let m = v - c;
    let (r, g, b) = match (h / 60.0) as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    [r, g, b].map(|u| ((u + m) * 255.0).round() as u8)
}

/// Colours each key-component distinctly, grey elsewhere (later components paint over earlier
/// ones where they overlap).
pub fn component_colors(mesh: &Mesh, det: &Detection) -> Vec<[u8; 3]> {
    let mut cols = vec![GREY; mesh.num_vertices()];
    for c in &det.components {
        let col = distinct(c.id);
        for &v in &c.vertices {
            cols[v as usize] = col;
        }
    }
    cols
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_ends() {
        assert_eq!(colormap(0.0), [68, 1, 84]);
        assert_eq!(colormap(1.0), [253, 231, 37]);
        assert_eq!(colormap(f64::NAN), [68, 1, 84]);
    }

    #[test]
    fn rank_colours_follow_order_and_grey_out_nan() {
        let c = by_rank(&[3.0, f64::NAN, -1.0, 10.0]);
        assert_eq!(c[1], GREY);
        assert_eq!(c[2], colormap(0.0));
        assert_eq!(c[3], colormap(1.0));
        assert_eq!(c[0], colormap(0.5));
    }

    #[test]
    fn distinct_colours_differ() {
        let cs: Vec<_> = (0..12).map(distinct).collect();
        for i in 0..cs.len() {
            for j in 0..i {
                assert_ne!(cs[i], cs[j]);
            }
        }
    }
}
