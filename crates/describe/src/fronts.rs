//! Geodesic fronts from part centres ([`Fronts`]): each centre's fast-marching front
//! (`keycomp_geodesic`) runs once, as far as the farthest use asks, from whichever thread asks
//! first; the others wait for it. A part's vertices and its row of the layout are read from its
//! centre's front, so what a description holds does not depend on the order fronts ran in or on
//! the thread count.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use keycomp_geodesic::GeodesicSolver;

use crate::error::DescribeError;

/// A front from a part centre: distances up to `limit` (+∞ beyond), `complete` when it covered
/// its whole connected piece.
pub(crate) struct Front {
    limit: f64,
    pub(crate) complete: bool,
    pub(crate) d: Vec<f64>,
}

impl Front {
    /// Whether this front measures everything a front stopped at `limit` measures.
    fn covers(&self, limit: f64) -> bool {
        self.complete || self.limit >= limit
    }
}

/// Fronts from part centres, computed once per centre (again only when a longer reach is
/// asked), from any thread: a thread asking for a centre another is running waits for that
/// front instead of running it twice, and the cache keeps the longest front of each centre, so
/// what it holds once a set of fronts has been asked for does not depend on the order they ran
/// in.
pub(crate) struct Fronts<'a> {
    solver: &'a GeodesicSolver,
    /// Workspaces not in use (one per thread that ran a front).
    spare: Mutex<Vec<keycomp_geodesic::Workspace>>,
    /// Per centre, its longest front so far.
    done: Mutex<HashMap<u32, Arc<Slot>>>,
}

/// A centre's longest front so far, locked while a front from it runs.
type Slot = Mutex<Option<Arc<Front>>>;

impl<'a> Fronts<'a> {
    pub(crate) fn new(solver: &'a GeodesicSolver) -> Self {
        Fronts {
            solver,
            spare: Mutex::new(Vec::new()),
            done: Mutex::new(HashMap::new()),
        }
    }

    /// The front from `c` up to at least `limit`.
    pub(crate) fn get(&self, c: u32, limit: f64) -> Result<Arc<Front>, DescribeError> {
        let slot = lock(&self.done).entry(c).or_default().clone();
        let mut slot = lock(&slot);
        if let Some(f) = slot.as_ref().filter(|f| f.covers(limit)) {
            return Ok(f.clone());
        }
        let spare = lock(&self.spare).pop();
        let mut ws = spare.unwrap_or_else(|| self.solver.workspace());
        let complete = self.solver.solve_within(c, limit, &mut ws)?;
        let front = Front {
            limit,
            complete,
            d: ws.distances().to_vec(),
        };
        lock(&self.spare).push(ws);
        let front = Arc::new(front);
        // what the slot held did not cover `limit`: this front reaches farther
        *slot = Some(front.clone());
        Ok(front)
    }
}

/// Locks `m`, whether or not another thread panicked while holding it (the data are plain
/// caches, complete after every write).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
