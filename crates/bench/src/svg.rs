//! Repeatability-vs-overlap plots as standalone SVG, in the manner of Figs. 7–9 of Sipiran &
//! Bustos (2013): overlap threshold o on the x axis (0 to 1), repeatability (the fraction of
//! transformed components whose best overlap exceeds o) on the y axis (0 to 1), one polyline
//! with markers per transformation, a legend on the right. Hand-written SVG 1.1, no scripts, no
//! external resources; the text is deterministic for given input.

use std::fmt::Write as _;

/// One curve: a label and one value per threshold.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Legend text.
    pub label: String,
    /// y values (repeatability in [0, 1]), one per threshold.
    pub values: Vec<f64>,
}

/// Distinct colours (the Okabe–Ito palette with its pale yellow last, plus wine and grey) used
/// in curve order.
const COLORS: [&str; 10] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#882255",
    "#999999", "#F0E442",
];

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Renders the plot. `thresholds` are the x values shared by every curve (values outside
/// [0, 1] and non-finite points are clamped or skipped); `title` goes on top.
pub fn repeatability_svg(title: &str, thresholds: &[f64], curves: &[Curve]) -> String {
    line_plot_svg(title, "Overlap", "Repeatability", thresholds, curves)
}

/// The same kind of plot with other axis labels: x and y both in [0, 1] (values outside are
/// clamped, non-finite points skipped), one polyline with markers per curve, a legend.
pub fn line_plot_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    thresholds: &[f64],
    curves: &[Curve],
) -> String {
    const W: f64 = 760.0;
    const H: f64 = 480.0;
    const LEFT: f64 = 70.0;
    const RIGHT: f64 = 190.0;
    const TOP: f64 = 50.0;
    const BOTTOM: f64 = 60.0;
    let pw = W - LEFT - RIGHT;
    let ph = H - TOP - BOTTOM;
    let x = |v: f64| LEFT + v.clamp(0.0, 1.0) * pw;
    let y = |v: f64| TOP + (1.0 - v.clamp(0.0, 1.0)) * ph;

    let mut s = String::new();
    // writing into a String cannot fail
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="Helvetica, Arial, sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="28" text-anchor="middle" font-size="16">{}</text>"#,
        LEFT + pw / 2.0,
        escape(title)
    );
    // grid and ticks every 0.1
    for i in 0..=10 {
        let v = f64::from(i) / 10.0;
        let (gx, gy) = (x(v), y(v));
        let _ = writeln!(
            s,
            r##"<line x1="{gx:.1}" y1="{TOP}" x2="{gx:.1}" y2="{:.1}" stroke="#e6e6e6"/>"##,
            TOP + ph
        );
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{gy:.1}" x2="{:.1}" y2="{gy:.1}" stroke="#e6e6e6"/>"##,
            LEFT + pw
        );
        let _ = writeln!(
            s,
            r#"<line x1="{gx:.1}" y1="{:.1}" x2="{gx:.1}" y2="{:.1}" stroke="black"/><text x="{gx:.1}" y="{:.1}" text-anchor="middle">{v:.1}</text>"#,
            TOP + ph,
            TOP + ph + 5.0,
            TOP + ph + 20.0
        );
        let _ = writeln!(
            s,
            r#"<line x1="{:.1}" y1="{gy:.1}" x2="{LEFT}" y2="{gy:.1}" stroke="black"/><text x="{:.1}" y="{:.1}" text-anchor="end">{v:.1}</text>"#,
            LEFT - 5.0,
            LEFT - 8.0,
            gy + 4.0
        );
    }
    // axes and their labels
    let _ = writeln!(
        s,
        r#"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
        LEFT + pw / 2.0,
        H - 15.0,
        escape(x_label)
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{:.1}" text-anchor="middle" transform="rotate(-90 18 {:.1})">{}</text>"#,
        TOP + ph / 2.0,
        TOP + ph / 2.0,
        escape(y_label)
    );
    // curves
    for (i, c) in curves.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let pts: Vec<(f64, f64)> = thresholds
            .iter()
            .zip(&c.values)
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .map(|(&t, &v)| (x(t), y(v)))
            .collect();
        let list: Vec<String> = pts.iter().map(|(a, b)| format!("{a:.1},{b:.1}")).collect();
        let _ = writeln!(
            s,
            r#"<polyline fill="none" stroke="{color}" stroke-width="2" points="{}"/>"#,
            list.join(" ")
        );
        for (a, b) in &pts {
            let _ = writeln!(
                s,
                r#"<circle cx="{a:.1}" cy="{b:.1}" r="2.5" fill="{color}"/>"#
            );
        }
        // legend entry
        let ly = TOP + 10.0 + 22.0 * i as f64;
        let lx = LEFT + pw + 20.0;
        let _ = writeln!(
            s,
            r#"<line x1="{lx:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{color}" stroke-width="2"/><circle cx="{:.1}" cy="{ly:.1}" r="2.5" fill="{color}"/><text x="{:.1}" y="{:.1}">{}</text>"#,
            lx + 28.0,
            lx + 14.0,
            lx + 36.0,
            ly + 4.0,
            escape(&c.label)
        );
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_has_axes_a_polyline_per_curve_and_a_legend() {
        let t: Vec<f64> = (0..=20).map(|i| f64::from(i) / 20.0).collect();
        let curves = vec![
            Curve {
                label: "Scale".into(),
                values: vec![1.0; 21],
            },
            Curve {
                label: "Holes & <gaps>".into(),
                values: t.iter().map(|o| 1.0 - o).collect(),
            },
        ];
        let svg = repeatability_svg("KC-1", &t, &curves);
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(svg.matches("<circle").count(), 2 * 21 + 2);
        assert!(svg.contains("Holes &amp; &lt;gaps&gt;"));
        assert!(svg.contains(">Overlap<") && svg.contains(">Repeatability<"));
        assert!(svg.contains(">0.5<"));
        // y = 1 maps to the top of the plot, y = 0 to the bottom
        assert!(svg.contains("70.0,50.0"), "{svg}");
        assert!(svg.contains("570.0,420.0"), "{svg}");
        assert_eq!(svg, repeatability_svg("KC-1", &t, &curves));
    }
}
