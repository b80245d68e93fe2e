//! The search structure of a snapshot ([`crate::IndexReader`]): which one a search uses
//! ([`SearchMode`]: the exact KD-tree, `kiddo`'s `ImmutableKdTree`, or the inverted file of
//! [`crate::ivf`]), what it holds once built, and where it came from ([`SearchSource`]: built
//! from the descriptors, or read from the search cache).

use std::time::Duration;

use kiddo::immutable::float::kdtree::ImmutableKdTree;

use crate::ivf::Ivf;

/// Components from which [`SearchMode::Auto`] searches an inverted file instead of the exact
/// KD-tree (about 390 shapes of 84 parts).
pub const IVF_MIN_COMPONENTS: usize = 32_768;

/// Components above which the exact search ([`SearchMode::Exact`]) scans the descriptors in
/// place, every query part of a batch in one pass, instead of building a KD-tree over a copy
/// of them (`4·D + 4` bytes per component: 1 GiB at 64 values); at that size the tree is near
/// a linear scan anyway for 64-value descriptors (BENCHMARKS.md, *The index at scale*).
pub const EXACT_TREE_MAX: usize = 1 << 22;

/// How [`IndexReader::nearest_components`](crate::IndexReader::nearest_components) searches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SearchMode {
    /// Exact below [`IVF_MIN_COMPONENTS`] components, approximate from there (the default).
    #[default]
    Auto,
    /// Always exact (the KD-tree).
    Exact,
    /// Always the inverted file (approximate: quantised residuals in k-means cells).
    Approximate,
}

/// Where a snapshot's search structure came from
/// ([`IndexReader::search_source`](crate::IndexReader::search_source)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchSource {
    /// Built from the descriptors: the exact KD-tree, or an inverted file without a usable
    /// search cache.
    Built,
    /// The inverted file read from the search cache written for this very snapshot.
    Cache,
    /// The inverted file read from a search cache written for an earlier snapshot: the
    /// `assigned` components of shapes added since were put in their nearest cells (no new
    /// k-means), those of shapes removed since left out. The cache is rewritten for this
    /// snapshot.
    CacheUpdated {
        /// Components put in their nearest cells.
        assigned: usize,
    },
}

/// The exact search's KD-tree over every live descriptor (bucket 128, `u32` items).
pub(crate) type Tree<const D: usize> = ImmutableKdTree<f32, u32, D, 128>;

/// The search structure, built on first use.
pub(crate) struct Search<const D: usize> {
    /// `None` when there is no component, when the inverted file is used, or when building the
    /// tree failed (then searches scan linearly).
    pub tree: Option<Tree<D>>,
    /// The inverted file, when the mode asks for it.
    pub ivf: Option<Ivf>,
    /// Where the structure came from.
    pub source: SearchSource,
    /// How long building it (or reading it from the cache) took.
    pub build_time: Duration,
}
