//! HTML reports of queries (`keycomp query --report DIR`, `keycomp demo`), results first: each
//! query's picture large, with the parts its best result matched each in its own colour, then
//! its results as pictures with rank, score and verified share, each with the parts matched to
//! the query's in the same colours (unmatched parts dark grey, larger parts under smaller ones,
//! the whole-surface part not drawn); the matched pairs and the query's parts are folded away
//! below.
//!
//! Result meshes are read from the indexed paths. The index keeps each component's centre
//! vertex and area fraction but not its vertex set, so a result's component is drawn as the
//! region of that area around its centre (vertices taken in order of geodesic distance from
//! the centre, by fast marching, until their area reaches the stored fraction). A result whose file is missing or
//! whose content hash differs from the indexed one is listed without a picture, saying why.
//!
//! The report is built in a temporary sibling directory and moved into place with renames, so
//! `DIR` holds either the previous report or the new one, never a mixture.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use keycomp_describe::DIM;
use keycomp_geodesic::GeodesicSolver;
use keycomp_index::ContentHash;
use keycomp_index::ShapeRecord;
use keycomp_mesh::{Mesh, MeshError, Point3, Topology, Vector3, VertexId, read_input, read_mesh};
use keycomp_render::{RenderParams, render};
use keycomp_retrieval::Ranked;
use keycomp_surface::SurfaceParams;

use crate::colors;
use crate::output;
use keycomp::Analysed;
use keycomp::collection::Reader;

/// Colour of a result's components that match nothing.
const UNMATCHED: [u8; 3] = [110, 110, 110];

/// One query of a report.
pub struct QueryEntry<'a> {
    /// Heading (e.g. the query file name).
    pub title: String,
    /// Extra line under the heading (e.g. the true class), plain text.
    pub note: Option<String>,
    /// The query, read, detected and described.
    pub query: &'a Analysed,
    /// Its ranked results.
    pub results: &'a [Ranked],
}

/// Image sizes of a report.
#[derive(Debug, Clone, Copy)]
pub struct ReportParams {
    /// Side of the query pictures, pixels.
    pub query_size: u32,
    /// Side of the result pictures, pixels.
    pub result_size: u32,
}

impl Default for ReportParams {
    fn default() -> Self {
        ReportParams {
            query_size: 320,
            result_size: 220,
        }
    }
}

/// Escapes text for HTML element content and double-quoted attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The vertices geodesically nearest `centre` (fast marching with `solver`, built on `mesh`)
/// whose (barycentric) area adds up to `area_fraction` of the mesh's area: the picture of an
/// indexed component. Empty if `centre` is not a vertex of the mesh.
pub fn region_of_area(
    mesh: &Mesh,
    solver: &GeodesicSolver,
    centre: VertexId,
    area_fraction: f64,
) -> Vec<VertexId> {
    let Ok(dist) = solver.distance_field(centre) else {
        return Vec::new();
    };
    let areas = keycomp_mesh::geometry::vertex_areas(mesh);
    let total: f64 = areas.iter().sum();
    let mut order: Vec<VertexId> = (0..mesh.num_vertices() as VertexId)
        .filter(|&v| dist[v as usize].is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        dist[a as usize]
            .total_cmp(&dist[b as usize])
            .then(a.cmp(&b))
    });
    let mut acc = 0.0;
    let mut out = Vec::new();
    for v in order {
        if acc >= area_fraction * total {
            break;
        }
        acc += areas[v as usize];
        out.push(v);
    }
    out
}

/// A copy of `mesh` turned so its principal axes (of the area-weighted vertex covariance) lie
/// along x (largest spread), y and z (smallest), signed so the third moment is non-negative
/// along x and non-positive along y (long limbs hang down): the renderer's front view (from
/// +z) then shows the shape's broadest outline,
/// whatever rigid motion it came with. Vertex ids are unchanged.
pub fn principal_pose(mesh: &Mesh) -> Mesh {
    let w = keycomp_mesh::geometry::vertex_areas(mesh);
    let total: f64 = w.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return mesh.clone();
    }
    let c = mesh
        .positions
        .iter()
        .zip(&w)
        .map(|(p, &a)| p.coords * a)
        .sum::<Vector3<f64>>()
        / total;
    let mut cov = Vector3::zeros() * Vector3::zeros().transpose();
    for (p, &a) in mesh.positions.iter().zip(&w) {
        let d = p.coords - c;
        cov += d * d.transpose() * a;
    }
    let eig = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut axes: Vec<Vector3<f64>> = order
        .iter()
        .map(|&i| eig.eigenvectors.column(i).into_owned())
        .collect();
    // x: the longer tail towards +x; y: the longer tail (legs, tentacles) downwards.
    for (k, axis) in axes.iter_mut().take(2).enumerate() {
        let skew: f64 = mesh
            .positions
            .iter()
            .zip(&w)
            .map(|(p, &a)| a * (p.coords - c).dot(axis).powi(3))
            .sum();
        if (k == 0 && skew < 0.0) || (k == 1 && skew > 0.0) {
            *axis = -*axis;
        }
    }
    axes[2] = axes[0].cross(&axes[1]);
    if !axes.iter().all(|a| a.iter().all(|x| x.is_finite())) {
        return mesh.clone();
    }
    Mesh {
        positions: mesh
            .positions
            .iter()
            .map(|p| {
                let d = p.coords - c;
                Point3::new(d.dot(&axes[0]), d.dot(&axes[1]), d.dot(&axes[2]))
            })
            .collect(),
        faces: mesh.faces.clone(),
    }
}

/// The mesh an indexed shape was analysed on, read from `path` (its indexed path): the file,
/// or its canonical surface of `surface` when the index's profile has one (the vertex ids of
/// its parts' centres are that mesh's), with a geodesic solver on it. Why not, when the file
/// is gone, unreadable or changed since it was indexed (its content hash is not `expected`).
pub(crate) fn load_indexed(
    path: &Path,
    expected: ContentHash,
    surface: Option<&SurfaceParams>,
) -> Result<(Mesh, GeodesicSolver), String> {
    match ContentHash::of_file(path) {
        Err(_) if !path.exists() => return Err("the file is gone".into()),
        Err(e) => return Err(format!("the file cannot be read: {e}")),
        Ok(h) if h != expected => return Err("the file has changed since it was indexed".into()),
        Ok(_) => {}
    }
    let unreadable = |e: MeshError| format!("the file cannot be read: {e}");
    let mesh = match surface {
        None => read_mesh(path).map_err(unreadable)?.mesh,
        Some(params) => {
            let input = read_input(path).map_err(unreadable)?;
            keycomp::analysis::canonical_surface(&input.geometry, params)
                .map_err(|e| format!("its canonical surface cannot be made: {e}"))?
                .mesh
        }
    };
    let solver = GeodesicSolver::new(&mesh, &Topology::new(&mesh))
        .map_err(|e| format!("the mesh cannot be measured: {e}"))?;
    Ok((mesh, solver))
}

/// The canonical surface the index's shapes were analysed on (its profile's), if any.
pub(crate) fn index_surface(reader: &Reader) -> Option<SurfaceParams> {
    serde_json::from_str::<keycomp::Profile>(reader.profile())
        .ok()
        .and_then(|p| p.surface)
}

/// Parts covering at least this share of the surface (the whole-surface part, a part of every
/// shape) are not coloured: they would hide every other.
pub(crate) const WHOLE: f64 = 0.99;

/// Per-vertex colours of a mesh of `n` vertices: `base`, then each region `(share of the
/// surface, vertices, colour)` painted larger first, so smaller ones stay visible on them;
/// regions covering the whole surface ([`WHOLE`]) are skipped.
pub(crate) fn paint_regions<R: AsRef<[VertexId]>>(
    n: usize,
    mut regions: Vec<(f64, R, [u8; 3])>,
    base: [u8; 3],
) -> Vec<[u8; 3]> {
    regions.retain(|r| r.0 < WHOLE);
    regions.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut cols = vec![base; n];
    for (_, vertices, col) in regions {
        for &v in vertices.as_ref() {
            if let Some(c) = cols.get_mut(v as usize) {
                *c = col;
            }
        }
    }
    cols
}

/// Per-vertex colours of an indexed shape's `mesh` (with its `solver`): each `(part, colour)`
/// of `paint` drawn as the region of the part's indexed area around its indexed centre
/// ([`region_of_area`]), as [`paint_regions`] paints; parts the record does not have, or whose
/// centre is not a vertex of `mesh`, are skipped.
pub(crate) fn paint_parts(
    mesh: &Mesh,
    solver: &GeodesicSolver,
    record: &ShapeRecord<DIM>,
    paint: &[(usize, [u8; 3])],
    base: [u8; 3],
) -> Vec<[u8; 3]> {
    let regions = paint
        .iter()
        .filter_map(|&(part, col)| {
            let c = record.components.get(part)?;
            let share = f64::from(c.area_fraction);
            // a whole-surface part would be skipped by `paint_regions`: not grown at all
            ((c.centre_vertex as usize) < mesh.num_vertices() && share < WHOLE).then(|| {
                let region = region_of_area(mesh, solver, c.centre_vertex, share);
                (share, region, col)
            })
        })
        .collect();
    paint_regions(mesh.num_vertices(), regions, base)
}

/// Per-vertex colours of a query's mesh: each `(part, colour)` of `paint`, a part of its
/// description under scale hypothesis `h`, as [`paint_regions`] paints.
pub(crate) fn paint_query_parts(
    q: &Analysed,
    h: usize,
    paint: &[(usize, [u8; 3])],
    base: [u8; 3],
) -> Vec<[u8; 3]> {
    let parts = &q.hypothesis(h).components;
    let regions = paint
        .iter()
        .filter_map(|&(part, col)| {
            parts
                .get(part)
                .map(|c| (c.area, c.vertices.as_slice(), col))
        })
        .collect();
    paint_regions(q.mesh_of(h).num_vertices(), regions, base)
}

/// A PNG of `mesh` in its [`principal_pose`], seen from the front, a little from the right
/// and above, `size` pixels square.
pub(crate) fn picture(mesh: &Mesh, cols: &[[u8; 3]], size: u32) -> Result<Vec<u8>> {
    let rp = RenderParams {
        size,
        azimuth_deg: 20.0,
        elevation_deg: 15.0,
        ..RenderParams::default()
    };
    let image = render(&principal_pose(mesh), cols, &rp).context("rendering failed")?;
    image.to_png_bytes().context("PNG encoding failed")
}

/// Writes [`picture`] to `path`.
fn png(mesh: &Mesh, cols: &[[u8; 3]], size: u32, path: &Path) -> Result<()> {
    let bytes = picture(mesh, cols, size)?;
    std::fs::write(path, bytes).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(())
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}
h1{font-size:1.4em}h2{font-size:1.15em;margin-top:2em;border-top:1px solid #ccc;padding-top:1em}
.query{display:flex;gap:1.5em;align-items:flex-start}figure{margin:0}
.results{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}
figure.result{border:1px solid #ddd;border-radius:6px;padding:6px}
figcaption{font-size:0.85em;max-width:240px;overflow-wrap:anywhere}
details{margin-top:0.6em;font-size:0.9em}
.sw{display:inline-block;width:0.9em;height:0.9em;border:1px solid #555;vertical-align:middle;margin-right:4px}
.missing{width:220px;height:60px;display:flex;align-items:center;color:#a33;font-size:0.9em}
.note{color:#555}code{font-size:0.9em}";

/// Writes `DIR/index.html` and its PNG pictures for `entries`, replacing a previous report in
/// `DIR`. Refuses to replace a directory that is not empty and has no `index.html` (so it never
/// deletes something that is not a report). Returns the path of `index.html`.
pub fn write_report(
    dir: &Path,
    reader: &Reader,
    entries: &[QueryEntry],
    params: &ReportParams,
) -> Result<PathBuf> {
    // A symbolic link to a folder stays a link: the report replaces the folder it points to.
    let dir = &keycomp_mesh::io::output::follow_links(dir)
        .with_context(|| format!("{}: cannot follow the link", dir.display()))?;
    output::check_output_folder(dir)?;
    if dir.exists() {
        let is_empty = std::fs::read_dir(dir)
            .with_context(|| format!("{}: cannot read the report directory", dir.display()))?
            .next()
            .is_none();
        if !is_empty && !dir.join("index.html").is_file() {
            bail!(
                "{}: exists and is not a keycomp report (no index.html); choose another --report directory",
                dir.display()
            );
        }
    }
    keycomp::folders::replace_folder(dir, |tmp| build(tmp, reader, entries, params))?;
    Ok(dir.join("index.html"))
}

fn build(out: &Path, reader: &Reader, entries: &[QueryEntry], params: &ReportParams) -> Result<()> {
    let surface = index_surface(reader);
    let mut cache: HashMap<PathBuf, Result<(Mesh, GeodesicSolver), String>> = HashMap::new();
    let mut h = String::new();
    writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>keycomp query report</title>\n<style>{STYLE}</style></head><body>"
    )?;
    writeln!(
        h,
        "<h1>keycomp query report</h1>\n<p class=\"note\">Index <code>{}</code>, {} shapes. \
         Each query is drawn with the parts its best result matched, each in its own colour; \
         each result with the parts matched to the query's in the same colours (a query part \
         keeps its colour in every result), unmatched parts dark grey, larger parts under \
         smaller ones. Result parts are drawn as the region of their indexed area around \
         their indexed centre (the index keeps centres and areas, not vertex sets).</p>",
        escape(&reader.dir().display().to_string()),
        reader.len()
    )?;
    for (qi, e) in entries.iter().enumerate() {
        let q = e.query;
        writeln!(h, "<h2>{}</h2>", escape(&e.title))?;
        if let Some(n) = &e.note {
            writeln!(h, "<p class=\"note\">{}</p>", escape(n))?;
        }
        // the query with the parts its best result matched
        let (top_h, top_matches) = e
            .results
            .first()
            .map_or((0, &[][..]), |r| (r.hypothesis, &r.result.matches[..]));
        let paint: Vec<(usize, [u8; 3])> = top_matches
            .iter()
            .map(|m| (m.query, colors::distinct(m.query)))
            .collect();
        let qimg = format!("q{:02}.png", qi + 1);
        let cols = paint_query_parts(q, top_h, &paint, colors::GREY);
        png(q.mesh_of(top_h), &cols, params.query_size, &out.join(&qimg))?;
        writeln!(
            h,
            "<div class=\"query\"><figure><img src=\"{qimg}\" width=\"{s}\" height=\"{s}\" alt=\"query {}\"><figcaption>the query: {} vertices, {} parts</figcaption></figure>",
            escape(&e.title),
            q.mesh_of(top_h).num_vertices(),
            q.hypothesis(top_h).components.len(),
            s = params.query_size
        )?;
        if e.results.is_empty() {
            writeln!(h, "<p>No indexed shape matches this query.</p></div>")?;
        } else {
            writeln!(h, "<div class=\"results\">")?;
        }
        let mut details = String::new();
        for (ri, r) in e.results.iter().enumerate() {
            let Some(rec) = reader.get(r.id)? else {
                continue;
            };
            let src = rec.canonical_path.clone();
            let loaded = cache
                .entry(src.clone())
                .or_insert_with(|| load_indexed(&src, rec.content_hash, surface.as_ref()));
            let picture = match loaded {
                Ok((mesh, solver)) => {
                    let matched: Vec<usize> = r.result.matches.iter().map(|m| m.target).collect();
                    let paint: Vec<(usize, [u8; 3])> = (0..rec.components.len())
                        .filter(|c| !matched.contains(c))
                        .map(|c| (c, UNMATCHED))
                        .chain(
                            r.result
                                .matches
                                .iter()
                                .map(|m| (m.target, colors::distinct(m.query))),
                        )
                        .collect();
                    let cols = paint_parts(mesh, solver, &rec, &paint, colors::GREY);
                    let img = format!("q{:02}-r{:02}.png", qi + 1, ri + 1);
                    png(mesh, &cols, params.result_size, &out.join(&img))?;
                    format!(
                        "<img src=\"{img}\" width=\"{s}\" height=\"{s}\" alt=\"result {}\">",
                        ri + 1,
                        s = params.result_size
                    )
                }
                Err(why) => {
                    format!("<div class=\"missing\">no picture: {}</div>", escape(why))
                }
            };
            let path = escape(&rec.path.display().to_string());
            writeln!(
                h,
                "<figure class=\"result\">{picture}<figcaption><b>#{} &nbsp;{:.3}</b>{}<br><code>{path}</code></figcaption></figure>",
                ri + 1,
                r.result.score,
                r.result
                    .verified
                    .map_or(String::new(), |f| format!(", verified {:.0} %", 100.0 * f)),
            )?;
            write!(
                details,
                "<li><code>{path}</code>: score {:.3}, {} of {} query parts matched{}<ul>",
                r.result.score,
                r.result.matches.len(),
                q.hypothesis(r.hypothesis).components.len(),
                if r.result.rejected > 0 {
                    format!(", {} dropped by the layout check", r.result.rejected)
                } else {
                    String::new()
                }
            )?;
            for m in &r.result.matches {
                write!(
                    details,
                    "<li><span class=\"sw\" style=\"background:{}\"></span>query part {} ↔ part {} (distance {:.3})</li>",
                    hex(colors::distinct(m.query)),
                    m.query,
                    m.target,
                    m.distance
                )?;
            }
            details.push_str("</ul></li>");
        }
        if !e.results.is_empty() {
            writeln!(h, "</div></div>")?;
            writeln!(
                h,
                "<details><summary>matched parts of each result</summary><ul>{details}</ul></details>"
            )?;
        }
        // the parts the picture's numbers and colours refer to: those of the best result's
        // scale hypothesis
        let parts = &q.hypothesis(top_h).components;
        writeln!(
            h,
            "<details><summary>the query's {} parts</summary><ul>",
            parts.len()
        )?;
        for (i, c) in parts.iter().enumerate() {
            writeln!(
                h,
                "<li>part {i}: {:.1} % of the area, {} keypoints</li>",
                c.area * 100.0,
                c.keypoints
            )?;
        }
        writeln!(h, "</ul></details>")?;
    }
    writeln!(h, "</body></html>")?;
    std::fs::write(out.join("index.html"), h)
        .with_context(|| format!("{}: cannot write index.html", out.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    #[test]
    fn escape_covers_markup_and_quotes() {
        assert_eq!(escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
        assert_eq!(escape("plain/path.off"), "plain/path.off");
    }

    #[test]
    fn principal_pose_puts_the_longest_axis_on_x_and_keeps_shape() {
        // an ellipsoid-like sphere stretched along a tilted direction
        let mut m = synth::icosphere(3, 1.0);
        let r = keycomp_mesh::Vector3::new(1.0, 2.0, 0.5).normalize();
        for p in &mut m.positions {
            let along = p.coords.dot(&r);
            *p = Point3::from(p.coords + r * (2.0 * along) + Vector3::new(5.0, -3.0, 1.0));
        }
        let q = principal_pose(&m);
        let spread = |k: usize| q.positions.iter().map(|p| p[k].abs()).fold(0.0, f64::max);
        assert!((spread(0) - 3.0).abs() < 0.05, "{}", spread(0));
        assert!(spread(1) < 1.05 && spread(2) < 1.05);
        // a rotation: distances between vertices are kept, orientation too
        for (a, b) in [(0usize, 5usize), (3, 40), (17, 99)] {
            let d0 = (m.positions[a] - m.positions[b]).norm();
            let d1 = (q.positions[a] - q.positions[b]).norm();
            assert!((d0 - d1).abs() < 1e-9);
        }
        let vol = |m: &Mesh| {
            (0..m.num_faces())
                .map(|f| {
                    let [a, b, c] = m.triangle(f);
                    a.coords.dot(&b.coords.cross(&c.coords))
                })
                .sum::<f64>()
        };
        assert!((vol(&m) - vol(&q)).abs() < 1e-6 * vol(&m).abs());
    }

    #[test]
    fn region_of_area_grows_with_the_fraction_and_contains_the_centre() {
        let m = synth::icosphere(3, 1.0);
        let solver = GeodesicSolver::new(&m, &Topology::new(&m)).unwrap();
        let small = region_of_area(&m, &solver, 7, 0.1);
        let big = region_of_area(&m, &solver, 7, 0.4);
        assert_eq!(small[0], 7);
        assert!(small.len() < big.len());
        let n = m.num_vertices() as f64;
        assert!((small.len() as f64 / n - 0.1).abs() < 0.03);
        assert!((big.len() as f64 / n - 0.4).abs() < 0.03);
        assert!(region_of_area(&m, &solver, 7, 1.0).len() == m.num_vertices());
    }
}
