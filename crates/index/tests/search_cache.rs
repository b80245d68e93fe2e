//! The inverted file's cache: the first approximate search of a snapshot writes it, the next
//! reader of the same descriptors reads it and answers the same; after an add or a remove it
//! is updated (new shapes put in their nearest cells) rather than rebuilt, until the collection
//! has grown too much for its centroids; a damaged one is rebuilt.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use keycomp_index::{
    IndexReader, IndexWriter, SEARCH_CACHE_NAME, SearchMode, SearchSource, synthetic, verify,
};

const D: usize = 8;

fn answers(reader: &IndexReader<D>) -> Vec<Vec<(u64, usize)>> {
    (0..20)
        .map(|i| {
            let q = reader.shapes().unwrap()[i * 7].record.components[0].descriptor;
            reader
                .nearest_components(&q, 10)
                .expect("search")
                .into_iter()
                .map(|m| (m.shape.0, m.component))
                .collect()
        })
        .collect()
}

fn open(dir: &std::path::Path) -> IndexReader<D> {
    IndexReader::<D>::open(dir)
        .expect("open")
        .with_search_mode(SearchMode::Approximate)
}

#[test]
fn the_cache_is_written_reused_and_rebuilt_when_stale_or_damaged() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path();
    let mut w = IndexWriter::<D>::create_or_open(dir).expect("writer");
    w.add_batch(synthetic::records(4, 0..400)).expect("add");
    let first = open(dir);
    let want = answers(&first);
    assert!(!first.search_was_cached());
    assert!(dir.join(SEARCH_CACHE_NAME).is_file());

    let second = open(dir);
    assert!(second.search_was_cached());
    assert_eq!(answers(&second), want);
    // the cache is no leftover: verify is clean and lists nothing
    let report = verify::<D>(dir).expect("verify");
    assert!(report.is_ok() && report.leftovers.is_empty(), "{report:?}");

    // after an add: updated, the new shapes' components put in their nearest cells, and each
    // found by its own descriptor; the next reader reads the updated cache as it is
    w.add_batch(synthetic::records(4, 400..450)).expect("add");
    let third = open(dir);
    let added: usize = third.shapes().unwrap()[400..]
        .iter()
        .map(|s| s.record.components.len())
        .sum();
    assert_eq!(
        third.search_source(),
        SearchSource::CacheUpdated { assigned: added }
    );
    for s in &third.shapes().unwrap()[400..] {
        let q = s.record.components[0].descriptor;
        let m = third.nearest_components(&q, 1).expect("search")[0];
        assert_eq!((m.shape, m.component), (s.id, 0));
    }
    assert_eq!(open(dir).search_source(), SearchSource::Cache);
    // after a remove: updated, nothing assigned
    let gone = third.shapes().unwrap()[3].record.canonical_path.clone();
    assert_eq!(w.remove(&[gone]).expect("remove"), 1);
    assert_eq!(
        open(dir).search_source(),
        SearchSource::CacheUpdated { assigned: 0 }
    );
    // more than twice the items the centroids were fitted on: built again
    w.add_batch(synthetic::records(4, 450..1300)).expect("add");
    assert_eq!(open(dir).search_source(), SearchSource::Built);
    let third = open(dir);
    assert_eq!(third.search_source(), SearchSource::Cache);

    // damaged: rebuilt with the same answers as a fresh build
    let path = dir.join(SEARCH_CACHE_NAME);
    let mut bytes = std::fs::read(&path).expect("read");
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xff;
    std::fs::write(&path, &bytes).expect("write");
    let fourth = open(dir);
    assert!(!fourth.search_was_cached());
    assert_eq!(answers(&fourth), answers(&third));
    std::fs::write(&path, b"not a cache").expect("write");
    assert!(!open(dir).search_was_cached());
}
