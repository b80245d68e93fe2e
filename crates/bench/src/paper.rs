//! The paper's published results, to print beside ours: average overlap per transformation
//! and cumulative strength for KC-1, KC-2 and KC-3 — Tables 1, 2 and 3 of I. Sipiran and
//! B. Bustos, "Key-components: detection of salient regions on 3D meshes", The Visual Computer
//! 29(12), 2013, Section 4.3 — and for the comparison method of Section 4.4, MSER and MSER
//! key-components (Tables 5 and 6) (SHREC'10 feature detection benchmark: three null shapes, nine
//! transformations × five strengths). Copied by hand from the paper's text; rows in the paper's
//! order, columns strength 1, ≤ 2, ≤ 3, ≤ 4, ≤ 5.

use serde::Serialize;

/// The transformations in the order of the paper's tables, as `(kind name, row label)`. The
/// kind names are [`crate::Kind`] names plus `isometry`.
pub const PAPER_ROWS: [(&str, &str); 9] = [
    ("isometry", "Isometry"),
    ("topology", "Topology"),
    ("microholes", "Micro holes"),
    ("scale", "Scale"),
    ("localscale", "Local scale"),
    ("sampling", "Sampling"),
    ("noise", "Noise"),
    ("shotnoise", "Shot noise"),
    ("holes", "Holes"),
];

/// Rows of ours beyond the paper's, after them in tables, and left out of the average row
/// (which stays comparable with the paper's): independent re-tessellations of the null shapes
/// and of the real poses (`keycomp bench repeatability --remeshed DIR`).
pub const EXTRA_ROWS: [(&str, &str); 2] = [
    ("retessellation", "Re-tessellation"),
    ("isometry-remeshed", "Isometry, remeshed"),
];

/// Whether a row counts in a table's average row: one of the paper's rows (when a table has
/// none of them, every row counts).
pub fn in_average(kind: &str) -> bool {
    PAPER_ROWS.iter().any(|(k, _)| *k == kind)
}

/// The table label of a kind name (`"microholes"` → `"Micro holes"`); the name itself if it is
/// not one of the paper's rows.
pub fn row_label(kind: &str) -> &str {
    PAPER_ROWS
        .iter()
        .chain(&EXTRA_ROWS)
        .find(|(k, _)| *k == kind)
        .map_or(kind, |(_, label)| label)
}

/// Position of a kind in the paper's row order (unknown kinds last).
pub fn row_order(kind: &str) -> usize {
    PAPER_ROWS
        .iter()
        .chain(&EXTRA_ROWS)
        .position(|(k, _)| *k == kind)
        .unwrap_or(PAPER_ROWS.len() + EXTRA_ROWS.len())
}

/// One of the paper's average-overlap tables.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PaperTable {
    /// Preset name as printed by [`keycomp_components::Preset`]'s `Display` (`KC-1`, …), or
    /// `MSER` / `MSER-KC`.
    pub preset: &'static str,
    /// Where the numbers are printed in the paper.
    pub source: &'static str,
    /// Per transformation (in [`PAPER_ROWS`] order): kind name and the five values.
    pub rows: [(&'static str, [f64; 5]); 9],
    /// The "Average" row.
    pub average: [f64; 5],
}

impl PaperTable {
    /// The paper's values for a kind name, if it is one of the rows.
    pub fn row(&self, kind: &str) -> Option<&[f64; 5]> {
        self.rows.iter().find(|(k, _)| *k == kind).map(|(_, v)| v)
    }
}

/// Tables 1–3 of the paper (key-components KC-1..3) and Tables 5–6 (the comparison method of
/// Section 4.4: Litman et al.'s MSER components and the MSER key-components).
pub const PAPER_TABLES: [PaperTable; 5] = [
    PaperTable {
        preset: "KC-1",
        source: "Sipiran & Bustos 2013, Table 1",
        rows: [
            ("isometry", [0.94, 0.95, 0.85, 0.93, 0.94]),
            ("topology", [0.75, 0.70, 0.84, 0.77, 0.74]),
            ("microholes", [0.93, 0.95, 0.95, 0.95, 0.93]),
            ("scale", [0.95, 0.95, 0.92, 0.93, 0.95]),
            ("localscale", [0.95, 0.87, 0.93, 0.88, 0.93]),
            ("sampling", [0.62, 0.38, 0.09, 0.02, 0.00]),
            ("noise", [0.92, 0.91, 0.93, 0.94, 0.86]),
            ("shotnoise", [0.93, 0.95, 0.96, 0.96, 0.94]),
            ("holes", [0.78, 0.69, 0.77, 0.86, 0.79]),
        ],
        average: [0.86, 0.82, 0.80, 0.80, 0.79],
    },
    PaperTable {
        preset: "KC-2",
        source: "Sipiran & Bustos 2013, Table 2",
        rows: [
            ("isometry", [0.85, 0.95, 0.78, 0.87, 0.87]),
            ("topology", [0.74, 0.64, 0.78, 0.71, 0.67]),
            ("microholes", [0.93, 0.95, 0.95, 0.95, 0.93]),
            ("scale", [0.95, 0.95, 0.92, 0.93, 0.95]),
            ("localscale", [0.95, 0.87, 0.93, 0.88, 0.87]),
            ("sampling", [0.58, 0.41, 0.24, 0.02, 0.00]),
            ("noise", [0.92, 0.91, 0.93, 0.94, 0.91]),
            ("shotnoise", [0.85, 0.87, 0.95, 0.95, 0.93]),
            ("holes", [0.68, 0.75, 0.70, 0.81, 0.74]),
        ],
        average: [0.83, 0.81, 0.80, 0.78, 0.76],
    },
    PaperTable {
        preset: "KC-3",
        source: "Sipiran & Bustos 2013, Table 3",
        rows: [
            ("isometry", [0.91, 0.94, 0.88, 0.94, 0.94]),
            ("topology", [0.87, 0.84, 0.86, 0.79, 0.78]),
            ("microholes", [0.86, 0.92, 0.93, 0.92, 0.86]),
            ("scale", [0.92, 0.93, 0.86, 0.86, 0.92]),
            ("localscale", [0.95, 0.87, 0.87, 0.91, 0.94]),
            ("sampling", [0.56, 0.23, 0.07, 0.02, 0.00]),
            ("noise", [0.90, 0.90, 0.92, 0.92, 0.86]),
            ("shotnoise", [0.86, 0.89, 0.90, 0.89, 0.95]),
            ("holes", [0.72, 0.65, 0.77, 0.83, 0.77]),
        ],
        average: [0.84, 0.80, 0.79, 0.79, 0.78],
    },
    PaperTable {
        preset: "MSER",
        source: "Sipiran & Bustos 2013, Table 5",
        rows: [
            ("isometry", [0.79, 0.87, 0.87, 0.88, 0.87]),
            ("topology", [0.75, 0.74, 0.65, 0.54, 0.57]),
            ("microholes", [0.79, 0.80, 0.79, 0.79, 0.77]),
            ("scale", [0.81, 0.87, 0.75, 0.63, 0.52]),
            ("localscale", [0.75, 0.72, 0.74, 0.65, 0.56]),
            ("sampling", [0.80, 0.80, 0.80, 0.62, 0.14]),
            ("noise", [0.79, 0.75, 0.76, 0.77, 0.76]),
            ("shotnoise", [0.81, 0.81, 0.80, 0.81, 0.82]),
            ("holes", [0.79, 0.79, 0.75, 0.75, 0.73]),
        ],
        average: [0.79, 0.79, 0.77, 0.71, 0.64],
    },
    PaperTable {
        preset: "MSER-KC",
        source: "Sipiran & Bustos 2013, Table 6",
        rows: [
            ("isometry", [0.83, 0.88, 0.90, 0.87, 0.86]),
            ("topology", [0.77, 0.72, 0.67, 0.52, 0.55]),
            ("microholes", [0.82, 0.81, 0.80, 0.79, 0.78]),
            ("scale", [0.76, 0.84, 0.80, 0.67, 0.58]),
            ("localscale", [0.77, 0.72, 0.71, 0.64, 0.58]),
            ("sampling", [0.83, 0.83, 0.80, 0.62, 0.12]),
            ("noise", [0.79, 0.79, 0.83, 0.83, 0.79]),
            ("shotnoise", [0.83, 0.83, 0.80, 0.80, 0.80]),
            ("holes", [0.79, 0.77, 0.66, 0.63, 0.62]),
        ],
        average: [0.80, 0.80, 0.78, 0.71, 0.63],
    },
];

/// The paper's table for a preset name (`KC-1`, `KC-2`, `KC-3`, `MSER`, `MSER-KC`).
pub fn paper_table(preset: &str) -> Option<&'static PaperTable> {
    PAPER_TABLES.iter().find(|t| t.preset == preset)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_complete_and_their_averages_match_the_rows() {
        for t in &PAPER_TABLES {
            for (i, (k, _)) in t.rows.iter().enumerate() {
                assert_eq!(*k, PAPER_ROWS[i].0);
            }
            // the printed averages are the row means rounded to two decimals (±0.01: the
            // paper averaged unrounded values)
            for c in 0..5 {
                let mean = t.rows.iter().map(|(_, v)| v[c]).sum::<f64>() / 9.0;
                assert!(
                    (mean - t.average[c]).abs() <= 0.011,
                    "{} column {c}: {mean} vs {}",
                    t.preset,
                    t.average[c]
                );
            }
        }
        assert_eq!(
            paper_table("KC-2").unwrap().row("sampling").unwrap()[1],
            0.41
        );
        assert_eq!(
            paper_table("MSER-KC").unwrap().row("holes").unwrap()[4],
            0.62
        );
        assert_eq!(paper_table("MSER").unwrap().average[4], 0.64);
        assert_eq!(row_label("microholes"), "Micro holes");
        assert_eq!(row_label("other"), "other");
        assert!(row_order("isometry") < row_order("holes"));
    }
}
