//! The squared Euclidean distance between descriptors, in two summation orders:
//! [`squared_distance`] adds the terms in order, as kiddo's `SquaredEuclidean` does, so that
//! the exact search's distances are the KD-tree's bit for bit; [`squared_distance_fast`] adds
//! them in eight partial sums, so that the loop vectorises (k-means, the inverted file, the
//! scan's norms). The two agree to rounding.

/// Squared Euclidean distance, summed in the same order as kiddo's `SquaredEuclidean`.
pub fn squared_distance<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let d = x - y;
            d * d
        })
        .sum()
}

/// Squared Euclidean distance over eight partial sums, so that the loop vectorises (the
/// summation order differs from [`squared_distance`]: results agree to rounding). `a` and `b`
/// have the same length.
#[inline]
pub fn squared_distance_fast(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            let d = x[l] - y[l];
            acc[l] += d * d;
        }
    }
    let mut tail = 0f32;
    for (x, y) in ra.iter().zip(rb) {
        let d = x - y;
        tail += d * d;
    }
    acc.iter().sum::<f32>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_matches_the_plain_sum() {
        let a: Vec<f32> = (0..67).map(|i| i as f32 * 0.1).collect();
        let b: Vec<f32> = (0..67).map(|i| (i as f32 * 0.37).sin()).collect();
        let plain: f32 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
        assert!((squared_distance_fast(&a, &b) - plain).abs() <= 1e-4 * plain);
    }
}
