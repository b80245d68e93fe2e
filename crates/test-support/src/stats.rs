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

#[cfg(test)]
mod tests {
    use super::*;

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
