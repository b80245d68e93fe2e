//! A shape as matching sees it ([`ShapeView`]): its parts' descriptors, the geodesic layout of
//! their centres, and optionally their areas, their centres' positions and a surface sample,
//! borrowed from a description (`keycomp_describe::ShapeDescription`) or an index record.

use keycomp_describe::Descriptor;

/// A shape as matching sees it: component descriptors and the `m × m` layout (row-major
/// geodesic distances between component centres, any unit).
#[derive(Debug, Clone, Copy)]
pub struct ShapeView<'a> {
    /// One descriptor per component.
    pub descriptors: &'a [Descriptor],
    /// Distances between centres, `m × m` row-major.
    pub layout: &'a [f32],
    /// Each part's area in the square of the layout's unit (or all of them times one common
    /// factor); empty: no area check.
    pub areas: &'a [f32],
    /// Each part's centre position in the layout's unit (any rigid motion of the whole
    /// shape); empty: no pose check and no verification.
    pub centres: &'a [[f32; 3]],
    /// Points on the surface, in the frame and unit of `centres` (`ShapeDescription::sample`
    /// of keycomp-describe); empty: no verification.
    pub sample: &'a [[f32; 3]],
}

impl ShapeView<'_> {
    /// Layout distance between the centres of parts `i` and `j` (NaN out of range).
    pub(crate) fn dist(&self, i: usize, j: usize) -> f64 {
        let m = self.descriptors.len();
        self.layout.get(i * m + j).copied().unwrap_or(f32::NAN) as f64
    }

    /// Straight-line distance between the centres of parts `i` and `j` (NaN without centres).
    pub(crate) fn straight(&self, i: usize, j: usize) -> f64 {
        match (self.centres.get(i), self.centres.get(j)) {
            (Some(a), Some(b)) => (0..3)
                .map(|k| (a[k] as f64 - b[k] as f64).powi(2))
                .sum::<f64>()
                .sqrt(),
            _ => f64::NAN,
        }
    }
}
