//! Summaries of measurements.

/// The median of `values`: the middle value of an odd count, the upper one of the two middle
/// values of an even count (a value that was measured, not a mean of two), and NaN for an
/// empty list. Values are ordered by `f64::total_cmp`, so NaNs sort last.
///
/// O(n log n) time (a sort of `values`).
///
/// ```
/// use keycomp_test_support::median;
///
/// assert_eq!(median(vec![12.0, 10.0, 11.0]), 11.0);
/// assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 3.0);
/// ```
pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The `q` quantile (0 to 1) of `sorted` (ascending): the value at the nearest rank
/// `round((n − 1)·q)`, a value that was measured; NaN for an empty list.
///
/// ```
/// use keycomp_test_support::quantile;
///
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.5), 3.0);
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.9), 5.0);
/// ```
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_measured_values_at_the_nearest_rank() {
        let v = [10.0, 20.0, 30.0, 40.0];
        assert_eq!(quantile(&v, 0.0), 10.0);
        assert_eq!(quantile(&v, 1.0), 40.0);
        // rank round(3 × 0.5) = 2
        assert_eq!(quantile(&v, 0.5), 30.0);
        assert!(quantile(&[], 0.5).is_nan());
    }

    #[test]
    fn odd_and_even_counts_and_the_empty_list() {
        assert_eq!(median(vec![3.0]), 3.0);
        assert_eq!(median(vec![5.0, 1.0, 4.0]), 4.0);
        // the upper of the two middle values
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 3.0);
        assert!(median(Vec::new()).is_nan());
    }

    #[test]
    fn negative_values_and_infinities_order_as_numbers() {
        assert_eq!(median(vec![f64::INFINITY, -2.0, -7.5]), -2.0);
        assert_eq!(median(vec![-0.5, f64::NEG_INFINITY, 10.0, 0.25, 1.0]), 0.25);
    }
}
