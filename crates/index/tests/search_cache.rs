//! The inverted file's cache: the first approximate search of a snapshot writes it, the next
//! reader of the same descriptors reads it and answers the same; an add makes it stale (then
//! rebuilt), and a damaged one is rebuilt.

use keycomp_index::{IndexReader, IndexWriter, SEARCH_CACHE_NAME, SearchMode, synthetic, verify};

const D: usize = 8;

fn answers(reader: &IndexReader<D>) -> Vec<Vec<(u64, usize)>> {
    (0..20)
        .map(|i| {
            let q = reader.shapes()[i * 7].record.components[0].descriptor;
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

    // stale after an add: rebuilt, and the new snapshot's answers
    w.add_batch(synthetic::records(4, 400..450)).expect("add");
    let third = open(dir);
    assert!(!third.search_was_cached());
    assert!(open(dir).search_was_cached());

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
