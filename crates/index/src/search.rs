//! The search over a snapshot ([`IndexReader::nearest_components`] and
//! [`IndexReader::nearest_components_batch`]): the `k` live components nearest to each query
//! descriptor, by squared Euclidean distance.
//!
//! The search structure is built on the first search (or [`IndexReader::prepare_search`]), so
//! that listing or looking up shapes does not pay for it:
//! - below [`IVF_MIN_COMPONENTS`] components, exact:
//!   [`kiddo::immutable::float::kdtree::ImmutableKdTree`] (bucket 128, `u32` items) over all
//!   live descriptors (bucket 128 is about 3× faster than kiddo's default 32 for 32-value
//!   descriptors). Building costs O(n log n); a query is O(log n) on well-clustered data and
//!   degrades towards a linear scan for high-dimensional data — which 64-value descriptors
//!   are;
//! - from there, approximate: an inverted file with a two-level k-means quantiser and
//!   residuals coded in two bytes per value ([`crate::ivf`]): about 12 cells of 512 codes
//!   scanned per search by their first bytes, the nearest ranked again by their whole codes,
//!   descriptors read only for the few codes too close to the `k`-th place to tell apart.
//!   [`SearchMode`] chooses otherwise; an exact search of more than [`EXACT_TREE_MAX`]
//!   components scans every descriptor in place instead of copying them into a tree
//!   ([`IndexReader::nearest_linear`]'s scan, every query of a batch in one pass).
//!
//! Neither structure is part of the index on disk: each spans all segments, so every add would
//! rewrite it whole. The inverted file is cached instead ([`SEARCH_CACHE_NAME`]): the reader
//! that builds it writes it, with each record's cells and codes by segment; later readers of
//! the same snapshot read it, and readers of a later snapshot (after an add or a remove) update
//! it — new records' parts go to their nearest cells, removed ones are left out — until the
//! collection has doubled or halved ([`SearchSource`]; `index/README.md`, "Search cache").
//! Distances are squared Euclidean: recomputed from the stored descriptors for the exact
//! search, as the codes give them for the approximate one ([`ComponentMatch::distance_sq`]).

use std::num::NonZero;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use kiddo::SquaredEuclidean;

use crate::dir::SEARCH_CACHE_NAME;
use crate::distance::{squared_distance, squared_distance_fast};
use crate::error::{IndexError, Result};
use crate::ivf::{Ivf, Points, SearchEffort, Settle};
use crate::reader::IndexReader;
use crate::record::ShapeId;
use crate::search_structure::{
    EXACT_TREE_MAX, IVF_MIN_COMPONENTS, Search, SearchMode, SearchSource, Tree,
};

/// One result of a component search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentMatch {
    /// The shape the component belongs to.
    pub shape: ShapeId,
    /// Index of the component in the shape's `components`.
    pub component: usize,
    /// Squared Euclidean distance between the query and the component's descriptor; with an
    /// approximate search ([`IndexReader::search_is_approximate`]), the distance to the
    /// descriptor as the inverted file's code of it stands for (its square root within
    /// [`IndexReader::code_error`] of the true one), so that descriptors are read only for
    /// the few components whose codes are too close to the `k`-th place to tell whether they
    /// are among the `k` nearest; theirs is the true distance.
    pub distance_sq: f32,
}

/// The live descriptors of a snapshot, in item order, read in place.
struct Live<'a, const D: usize>(&'a IndexReader<D>);

impl<const D: usize> Points for Live<'_, D> {
    fn len(&self) -> usize {
        self.0.component_count()
    }
    fn point(&self, i: u32) -> &[f32] {
        // Items below `len()` always have a descriptor (see `IndexReader::descriptor_slice`).
        self.0.descriptor_slice(i as usize).unwrap_or(&[])
    }
}

impl<const D: usize> IndexReader<D> {
    /// This snapshot searching as `mode` says (the search structure is built again on the next
    /// search).
    pub fn with_search_mode(mut self, mode: SearchMode) -> Self {
        self.mode = mode;
        self.search = OnceLock::new();
        self
    }

    /// This snapshot searching its inverted file with `effort` (no effect on the exact
    /// search; the search structure is kept).
    pub fn with_search_effort(mut self, effort: SearchEffort) -> Self {
        self.effort = effort;
        self
    }

    /// How much of the inverted file an approximate search reads.
    pub fn search_effort(&self) -> SearchEffort {
        self.effort
    }

    /// Whether searches are approximate (the inverted file) for this snapshot and mode.
    pub fn search_is_approximate(&self) -> bool {
        match self.mode {
            SearchMode::Auto => self.component_count() >= IVF_MIN_COMPONENTS,
            SearchMode::Exact => false,
            SearchMode::Approximate => self.component_count() > 0,
        }
    }

    /// Builds the search structure now if it is not built yet (searches build it on first
    /// use). Returns the time the build took (once built, always the same value).
    pub fn prepare_search(&self) -> Duration {
        self.search().build_time
    }

    /// Whether the search structure (building it if needed) was read from the index's search
    /// cache ([`SEARCH_CACHE_NAME`]), as it was or updated, instead of being built.
    pub fn search_was_cached(&self) -> bool {
        self.search_source() != SearchSource::Built
    }

    /// Where the search structure (building it if needed) came from.
    pub fn search_source(&self) -> SearchSource {
        self.search().source
    }

    /// The inverted file of the live descriptors: read from the search cache when it fits this
    /// snapshot (records of segments added since put in their nearest cells, those removed
    /// since left out; the cache is then rewritten for this snapshot), else built and written
    /// there for the next reader (best effort: a read-only index folder, a damaged or stale
    /// cache only cost a build).
    fn inverted_file(&self) -> (Ivf, SearchSource) {
        let live = Live(self);
        let key = self.snapshot_key();
        let path = self.dir().join(SEARCH_CACHE_NAME);
        let mapped = crate::file::open_regular(&path)
            .ok()
            .and_then(|f| crate::file::map(&f, &path).ok());
        if let Some(bytes) = mapped
            && let Some(c) = Ivf::from_cache(&path, &bytes, key, &live, D, &self.origins)
        {
            drop(bytes);
            if c.exact {
                return (c.ivf, SearchSource::Cache);
            }
            let _ = c
                .ivf
                .write_cache(self.dir(), SEARCH_CACHE_NAME, key, &self.origins);
            return (
                c.ivf,
                SearchSource::CacheUpdated {
                    assigned: c.assigned,
                },
            );
        }
        let ivf = Ivf::build(&live, D);
        let _ = ivf.write_cache(self.dir(), SEARCH_CACHE_NAME, key, &self.origins);
        (ivf, SearchSource::Built)
    }

    /// How far the square root of an approximate search's distance may be from the true
    /// distance, for descriptors within the ranges its quantiser was fitted on (building the
    /// search structure if needed); 0 for the exact search.
    pub fn code_error(&self) -> f32 {
        self.search().ivf.as_ref().map_or(0.0, Ivf::code_error)
    }

    /// Bytes held by the search structure (building it if needed): the inverted file's, or
    /// an estimate of the KD-tree's (its copy of the descriptors and item ids).
    pub fn search_bytes(&self) -> usize {
        let s = self.search();
        match (&s.ivf, &s.tree) {
            (Some(ivf), _) => ivf.bytes(),
            (None, Some(_)) => self.component_count() * (4 * D + 4),
            (None, None) => 0,
        }
    }

    fn search(&self) -> &Search<D> {
        self.search.get_or_init(|| {
            let start = Instant::now();
            if self.search_is_approximate() {
                let (ivf, source) = self.inverted_file();
                return Search {
                    tree: None,
                    ivf: Some(ivf),
                    source,
                    build_time: start.elapsed(),
                };
            }
            if self.component_count() > EXACT_TREE_MAX {
                // exact searches scan the descriptors in place (`scan`)
                return Search {
                    tree: None,
                    ivf: None,
                    source: SearchSource::Built,
                    build_time: start.elapsed(),
                };
            }
            let points: Vec<[f32; D]> = (0..self.component_count())
                .filter_map(|i| self.descriptor(i).map(|(_, _, d)| *d))
                .collect();
            let tree = if points.is_empty() {
                None
            } else {
                // kiddo documents no panic for ImmutableKdTree construction, but it is
                // third-party code fed with data from disk: if it ever panics, fall back to
                // linear scans rather than taking the process down.
                std::panic::catch_unwind(|| Tree::<D>::new_from_slice(&points)).ok()
            };
            Search {
                tree,
                ivf: None,
                source: SearchSource::Built,
                build_time: start.elapsed(),
            }
        })
    }

    /// The `k` live components nearest to `query` (squared Euclidean distance), closest first;
    /// ties are ordered by shape id then component index. Fewer if the index has fewer. The
    /// approximate search ranks by, and returns, the distances the inverted file's codes give
    /// (see [`ComponentMatch::distance_sq`]).
    ///
    /// Errors with [`IndexError::InvalidQuery`] if `query` holds a NaN or infinity.
    pub fn nearest_components(&self, query: &[f32; D], k: usize) -> Result<Vec<ComponentMatch>> {
        check_finite(std::slice::from_ref(query))?;
        let Some(qty) = NonZero::new(k) else {
            return Ok(Vec::new());
        };
        let search = self.search();
        let items: Vec<usize> = match (&search.ivf, &search.tree) {
            (Some(ivf), _) => {
                let mut out = self.ivf_nearest(ivf, std::slice::from_ref(query), qty.get());
                return Ok(out.pop().unwrap_or_default());
            }
            (None, Some(tree)) => tree
                .nearest_n::<SquaredEuclidean>(query, qty)
                .into_iter()
                .map(|n| n.item as usize)
                .collect(),
            (None, None) => return Ok(self.nearest_linear(query, k)),
        };
        let mut out: Vec<ComponentMatch> = items
            .into_iter()
            .filter_map(|i| self.descriptor(i))
            .map(|(shape, component, d)| ComponentMatch {
                shape,
                component,
                distance_sq: squared_distance(query, d),
            })
            .collect();
        sort_matches(&mut out);
        Ok(out)
    }

    /// [`IndexReader::nearest_components`] for several query descriptors (e.g. all components
    /// of a query shape); one result list per query, in order. Queries run in parallel
    /// (rayon).
    pub fn nearest_components_batch(
        &self,
        queries: &[[f32; D]],
        k: usize,
    ) -> Result<Vec<Vec<ComponentMatch>>> {
        check_finite(queries)?;
        let search = self.search();
        match (&search.ivf, &search.tree) {
            (Some(ivf), _) => Ok(self.ivf_nearest(ivf, queries, k)),
            (None, None) => Ok(self.scan(queries, k)),
            (None, Some(_)) => queries
                .par_iter()
                .map(|q| self.nearest_components(q, k))
                .collect(),
        }
    }

    /// The approximate search of `queries` (finite), in parallel: distances as the codes give
    /// them, except for the codes too close to the `k`-th place to tell whether they are
    /// among the `k` nearest, whose descriptors are read (asked of the disk all at once, for
    /// all queries, before any is read).
    fn ivf_nearest(&self, ivf: &Ivf, queries: &[[f32; D]], k: usize) -> Vec<Vec<ComponentMatch>> {
        let found: Vec<Vec<(u32, f32, f32)>> = queries
            .par_iter()
            .map(|q| ivf.search_bounded(q, k, self.effort))
            .collect();
        let settled: Vec<Settle> = found.iter().map(|f| Settle::new(f, k)).collect();
        for &i in settled.iter().flat_map(|s| s.open()) {
            self.prefetch_item(i as usize);
        }
        queries
            .par_iter()
            .zip(settled)
            .map(|(query, settle)| {
                let exact = |i: u32| {
                    self.descriptor_slice(i as usize)
                        .map(|d| squared_distance_fast(query, d))
                };
                let mut out: Vec<ComponentMatch> = settle
                    .finish(exact)
                    .into_iter()
                    .filter_map(|(i, distance_sq)| {
                        let (shape, component) = self.item_owner(i as usize)?;
                        Some(ComponentMatch {
                            shape,
                            component,
                            distance_sq,
                        })
                    })
                    .collect();
                sort_matches(&mut out);
                out
            })
            .collect()
    }

    /// Exact `k` nearest components by scanning every descriptor (the oracle the KD-tree is
    /// tested against, and the fallback if the tree could not be built).
    pub fn nearest_linear(&self, query: &[f32; D], k: usize) -> Vec<ComponentMatch> {
        self.scan(std::slice::from_ref(query), k)
            .pop()
            .unwrap_or_default()
    }

    /// The exact `k` nearest components of each of `queries`, by one parallel pass over every
    /// descriptor (read in place): what the exact search does above [`EXACT_TREE_MAX`]
    /// components. The descriptors are taken a block at a time, and the block's squared
    /// distances to every query as `‖x‖² + ‖q‖² − 2 x·q`, the products as one matrix product
    /// (faer); a block's distances that cannot enter a query's kept ones are skipped eight at a
    /// time. The `2k` nearest so ranked are measured again in kiddo's summation order (the
    /// expansion loses digits to cancellation) and the `k` best kept, ordered as
    /// [`IndexReader::nearest_components`] orders them. Batching many queries into one call
    /// reads the descriptors once for all of them.
    fn scan(&self, queries: &[[f32; D]], k: usize) -> Vec<Vec<ComponentMatch>> {
        if k == 0 || queries.is_empty() {
            return vec![Vec::new(); queries.len()];
        }
        let keep = k.saturating_mul(2);
        let nq = queries.len();
        let q_flat: Vec<f32> = queries.iter().flatten().copied().collect();
        let q_norm: Vec<f32> = queries.iter().map(|q| norm_sq::<D>(q)).collect();
        // descriptors per block: the block's distance matrix stays within 4M values
        let block = ((1usize << 22) / nq).clamp(64, 4096);
        /// Per query: the kept (distance, item) pairs and the distance they must beat.
        struct Kept {
            found: Vec<Vec<(f32, u32)>>,
            bound: Vec<f32>,
        }
        let prune = |v: &mut Vec<(f32, u32)>| -> f32 {
            if v.len() >= keep {
                v.select_nth_unstable_by(keep - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                v.truncate(keep);
                v.iter().map(|x| x.0).fold(f32::NEG_INFINITY, f32::max)
            } else {
                f32::INFINITY
            }
        };
        let new_kept = || Kept {
            found: vec![Vec::new(); nq],
            bound: vec![f32::INFINITY; nq],
        };
        let n = self.component_count();
        let kept = (0..n.div_ceil(block))
            .into_par_iter()
            .fold(new_kept, |mut acc, chunk| {
                let items = chunk * block..((chunk + 1) * block).min(n);
                let mut x = Vec::with_capacity(items.len() * D);
                let mut ids = Vec::with_capacity(items.len());
                for i in items {
                    if let Some(d) = self.descriptor_slice(i) {
                        x.extend_from_slice(d);
                        ids.push(i as u32);
                    }
                }
                let b = ids.len();
                if b == 0 {
                    return acc;
                }
                let x_norm: Vec<f32> = x.chunks_exact(D).map(norm_sq::<D>).collect();
                let mut g = faer::Mat::<f32>::zeros(b, nq);
                faer::linalg::matmul::matmul(
                    g.as_mut(),
                    faer::Accum::Replace,
                    faer::MatRef::from_row_major_slice(&x, b, D),
                    faer::MatRef::from_row_major_slice(&q_flat, nq, D).transpose(),
                    -2.0f32,
                    faer::Par::Seq,
                );
                let mut dist = vec![0f32; b];
                for (q, &qn) in q_norm.iter().enumerate() {
                    let col = g.col(q);
                    for (r, (out, xn)) in dist.iter_mut().zip(&x_norm).enumerate() {
                        *out = xn + col[r];
                    }
                    // compared with the bound less the query's norm, eight at a time
                    let beat = acc.bound[q] - qn;
                    for (c, eight) in dist.chunks(8).enumerate() {
                        if eight.iter().copied().fold(f32::INFINITY, f32::min) >= beat {
                            continue;
                        }
                        for (r, &v) in eight.iter().enumerate() {
                            if v < beat {
                                let at = c * 8 + r;
                                acc.found[q].push((v + qn, ids[at]));
                            }
                        }
                    }
                    if acc.found[q].len() >= 2 * keep.max(64) {
                        acc.bound[q] = prune(&mut acc.found[q]);
                    }
                }
                acc
            })
            .reduce(new_kept, |mut a, b| {
                for (q, v) in b.found.into_iter().enumerate() {
                    a.found[q].extend(v);
                    prune(&mut a.found[q]);
                }
                a
            });
        kept.found
            .into_iter()
            .zip(queries)
            .map(|(mut v, q)| {
                prune(&mut v);
                let mut out: Vec<ComponentMatch> = v
                    .into_iter()
                    .filter_map(|(_, i)| self.descriptor(i as usize))
                    .map(|(shape, component, d)| ComponentMatch {
                        shape,
                        component,
                        distance_sq: squared_distance(q, d),
                    })
                    .collect();
                sort_matches(&mut out);
                out.truncate(k);
                out
            })
            .collect()
    }
}

/// Squared norm of `v`: its vectorised squared distance to the origin.
fn norm_sq<const D: usize>(v: &[f32]) -> f32 {
    squared_distance_fast(v, &[0.0; D])
}

/// [`IndexError::InvalidQuery`] naming the first value of `queries` that is NaN or infinite.
fn check_finite<const D: usize>(queries: &[[f32; D]]) -> Result<()> {
    match queries.iter().flatten().position(|v| !v.is_finite()) {
        Some(i) => Err(IndexError::InvalidQuery {
            reason: format!("descriptor value {} is not finite", i % D.max(1)),
        }),
        None => Ok(()),
    }
}

fn sort_matches(v: &mut [ComponentMatch]) {
    v.sort_by(|a, b| {
        a.distance_sq
            .total_cmp(&b.distance_sq)
            .then(a.shape.cmp(&b.shape))
            .then(a.component.cmp(&b.component))
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{IndexWriter, synthetic};

    /// One pass for several queries finds, for each, what the KD-tree finds.
    #[test]
    fn a_batched_scan_equals_the_tree() {
        const D: usize = 6;
        let dir = tempfile::tempdir().unwrap();
        let mut w = IndexWriter::<D>::create_or_open(dir.path()).unwrap();
        w.add_batch(synthetic::records::<D>(5, 0..300)).unwrap();
        w.add_batch(synthetic::records::<D>(5, 300..450)).unwrap();
        drop(w);
        let r = IndexReader::<D>::open_mapped(dir.path()).unwrap();
        let queries: Vec<[f32; D]> = (0..7)
            .map(|i| {
                let s = &r.shapes().unwrap()[i * 31];
                let mut q = s.record.components[0].descriptor;
                q[0] += 0.01 * i as f32;
                q
            })
            .collect();
        for k in [1, 5, 64] {
            let scanned = r.scan(&queries, k);
            for (q, got) in queries.iter().zip(&scanned) {
                assert_eq!(got, &r.nearest_components(q, k).unwrap(), "k {k}");
            }
        }
        assert!(r.scan(&queries, 0).iter().all(Vec::is_empty));
    }
}
