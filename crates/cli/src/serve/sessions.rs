//! The queries `keycomp serve` answered, kept for their 3D view: each query's analysed mesh
//! and its parts (what `keycomp query --analysis-out` writes), the last [`KEPT`] of them.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use keycomp_mesh::{Mesh, Point3};

use crate::colors;
use crate::commands::query::AnalysisOut;
use crate::report::paint_regions;

/// Queries kept.
pub(crate) const KEPT: usize = 16;

/// One answered query: per scale hypothesis, the mesh analysed and its parts.
pub(crate) struct Session {
    hypotheses: Vec<(Mesh, Vec<Vec<u32>>)>,
}

impl Session {
    /// From `keycomp query --analysis-out`'s JSON; why not when it is not that.
    pub(crate) fn from_json(bytes: &[u8]) -> Result<Session, String> {
        let a: AnalysisOut = serde_json::from_slice(bytes)
            .map_err(|e| format!("keycomp query wrote an unreadable analysis: {e}"))?;
        let mut hypotheses = Vec::with_capacity(a.hypotheses.len());
        for h in a.hypotheses {
            // the mesh keycomp analysed, ids kept: the parts' vertex ids are its
            let mesh = Mesh {
                positions: h
                    .positions
                    .iter()
                    .map(|p| Point3::new(p[0], p[1], p[2]))
                    .collect(),
                faces: h.faces,
            };
            let n = mesh.num_vertices();
            let outside = |v: &u32| *v as usize >= n;
            if mesh.faces.iter().flatten().any(outside) || h.parts.iter().flatten().any(outside) {
                return Err("keycomp query wrote vertex ids outside its mesh".into());
            }
            hypotheses.push((mesh, h.parts));
        }
        if hypotheses.is_empty() {
            return Err("keycomp query wrote an analysis without a mesh".into());
        }
        Ok(Session { hypotheses })
    }

    /// GLB of the mesh of scale hypothesis `h` (the first when there is no such hypothesis),
    /// the k-th of `parts` in the palette's k-th colour, grey elsewhere, painted as a shape's
    /// are (`paint_regions`, by share of the vertices here); parts it does not have are
    /// skipped.
    pub(crate) fn glb(&self, h: usize, parts: &[usize]) -> Vec<u8> {
        let (mesh, hyp) = self.hypotheses.get(h).unwrap_or(&self.hypotheses[0]);
        let n = mesh.num_vertices();
        let regions = parts
            .iter()
            .enumerate()
            .filter_map(|(k, &p)| {
                let part = hyp.get(p)?;
                Some((
                    part.len() as f64 / n as f64,
                    part.as_slice(),
                    colors::distinct(k),
                ))
            })
            .collect();
        let cols = paint_regions(n, regions, colors::GREY);
        keycomp_mesh::glb_bytes(mesh, Some(&cols))
    }
}

/// The last [`KEPT`] sessions, by number.
#[derive(Default)]
pub(crate) struct Sessions {
    kept: Mutex<Kept>,
}

#[derive(Default)]
struct Kept {
    /// The next session's number.
    next: u64,
    /// Newest first.
    list: VecDeque<(u64, Arc<Session>)>,
}

impl Sessions {
    /// Keeps `s` (dropping the oldest beyond [`KEPT`]); its number.
    pub(crate) fn insert(&self, s: Session) -> u64 {
        let mut kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        let id = kept.next;
        kept.next += 1;
        kept.list.push_front((id, Arc::new(s)));
        kept.list.truncate(KEPT);
        id
    }

    /// Session `id`, if still kept.
    pub(crate) fn get(&self, id: u64) -> Option<Arc<Session>> {
        let kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        kept.list
            .iter()
            .find(|(i, _)| *i == id)
            .map(|(_, s)| s.clone())
    }
}
