//! The search cache's payload (`SEARCH-CACHE` in the index folder; `index/README.md`, *Search
//! cache*): the inverted file's centroids and quantiser, then, segment by segment, the fine
//! cell and the code of every component of every record the cache was written for.
//!
//! The inverted file spans every segment, so it is not part of the index: a reader that builds
//! it writes it here ([`Ivf::write_cache`]), and later readers read it ([`Ivf::from_cache`]):
//! readers of the same snapshot as it is, readers of a later one keeping the cells and codes
//! of the records still live and putting the components of the others in their nearest cells
//! (no new k-means), until the collection has grown or shrunk by [`GROWTH`] times. The payload
//! is written and read one segment at a time, never whole in memory. A damaged cache, one of
//! another layout or format version, is rebuilt rather than misread.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::codec::{bincode_config, decode_bounded};
use crate::error::Result;
use crate::file::{self, FOOTER_LEN, KIND_SEARCH_CACHE};
use crate::version::FORMAT_VERSION;

use super::build::Points;
use super::lists::Ivf;
use super::quantiser::Sq;

/// The first field of a search cache's payload: caches whose payload is laid out otherwise
/// (an earlier layout of the same format version) are rebuilt instead of misread.
const CACHE_TAG: u64 = u64::from_le_bytes(*b"KCIVF16\0");

/// Where a shape's descriptors come from, as the search cache identifies them: a segment (its
/// number, length and checksum: segments are immutable) and the record's position in it.
/// Items are the shapes' components, shape after shape, in the order the caller lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Origin {
    /// The segment's number, length and checksum.
    pub segment: (u64, u64, u64),
    /// The record's position in the segment.
    pub position: u32,
    /// The shape's components (its items).
    pub components: u32,
}

/// The cells of one segment's records, as a cache file holds them.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct SegmentCells {
    /// The segment's number, length and checksum.
    segment: (u64, u64, u64),
    /// Positions in the segment of the records held, increasing.
    positions: Vec<u32>,
    /// Per record held, its first entry in `cells`; one more entry closes the last.
    starts: Vec<u32>,
    /// Global fine cell of each component of each record held.
    cells: Vec<u32>,
    /// The first byte per value of the code of each component of each record held, in the
    /// order of `cells`.
    #[serde(with = "serde_bytes")]
    codes: Vec<u8>,
    /// The second bytes of the same codes, in the same order.
    #[serde(with = "serde_bytes")]
    refine: Vec<u8>,
}

/// The start of a cache payload, as written (followed by a `u64` segment count and each
/// segment's [`SegmentCells`]).
#[derive(serde::Serialize)]
struct Head<'a> {
    tag: u64,
    key: u64,
    d: u32,
    trained: u64,
    coarse: &'a [f32],
    fine: &'a [Vec<f32>],
    pq: &'a Sq,
}

/// [`Head`] as read.
#[derive(serde::Deserialize)]
struct HeadOwned {
    tag: u64,
    key: u64,
    d: u32,
    trained: u64,
    coarse: Vec<f32>,
    fine: Vec<Vec<f32>>,
    pq: Sq,
}

/// What a cache file holds, as one value (the tests craft caches with it).
#[cfg(test)]
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct Stored {
    tag: u64,
    /// The snapshot key the cache was written for (equal: nothing to update).
    key: u64,
    d: u32,
    /// Items the centroids were fitted on.
    trained: u64,
    coarse: Vec<f32>,
    fine: Vec<Vec<f32>>,
    pq: Sq,
    segments: Vec<SegmentCells>,
}

/// An inverted file read from a cache file (see [`Ivf::from_cache`]).
pub(crate) struct FromCache {
    /// The inverted file of the current items.
    pub ivf: Ivf,
    /// Whether the cache was written for exactly these items (else it is worth rewriting).
    pub exact: bool,
    /// Items of records the cache did not hold, put in their nearest cells.
    pub assigned: usize,
}

/// A cache whose centroids were fitted on `trained` items is extended (new items put in their
/// nearest cells) only while the items number between `trained / GROWTH` and
/// `trained × GROWTH`; beyond, cells are too crowded or too sparse and the inverted file is
/// built again.
pub(crate) const GROWTH: usize = 2;

impl Ivf {
    /// The inverted file as a cache file for the snapshot identified by `key`, whose items
    /// come from `origins` (in item order): the centroids, the quantiser, and the cell and code
    /// of every item, grouped by segment, sealed like the index's files.
    pub(crate) fn to_cache(&self, key: u64, origins: &[Origin]) -> Vec<u8> {
        let mut payload = Vec::new();
        // writing into memory cannot fail
        let _ = self.write_payload(key, origins, &mut payload);
        file::seal(payload, KIND_SEARCH_CACHE, FORMAT_VERSION).0
    }

    /// [`Ivf::to_cache`] written to `dir/name` atomically, segment by segment (never the whole
    /// payload in memory).
    pub(crate) fn write_cache(
        &self,
        dir: &Path,
        name: &str,
        key: u64,
        origins: &[Origin],
    ) -> Result<PathBuf> {
        file::write_atomic_sealed(dir, name, KIND_SEARCH_CACHE, FORMAT_VERSION, |w| {
            self.write_payload(key, origins, w)
        })
    }

    /// The cache payload (see [`Ivf::to_cache`]) into `w`: the fields of [`Head`], the
    /// segment count, then each segment's [`SegmentCells`] (bincode, as one [`Stored`] would
    /// be encoded).
    fn write_payload(
        &self,
        key: u64,
        origins: &[Origin],
        w: &mut impl std::io::Write,
    ) -> std::io::Result<()> {
        let cell = self.cells();
        let place = self.places();
        let m = self.pq.bytes();
        // per segment: (record position, its first item, its items)
        type Records = Vec<(u32, usize, usize)>;
        let mut by_segment: BTreeMap<(u64, u64, u64), Records> = BTreeMap::new();
        let mut first = 0usize;
        for o in origins {
            let end = (first + o.components as usize).min(cell.len());
            by_segment
                .entry(o.segment)
                .or_default()
                .push((o.position, first, end - first));
            first = end;
        }
        let config = bincode_config();
        let enc = |e: bincode::error::EncodeError| std::io::Error::other(e.to_string());
        let head = Head {
            tag: CACHE_TAG,
            key,
            d: self.d as u32,
            trained: self.trained as u64,
            coarse: &self.coarse,
            fine: &self.fine,
            pq: &self.pq,
        };
        bincode::serde::encode_into_std_write(&head, w, config).map_err(enc)?;
        w.write_all(&(by_segment.len() as u64).to_le_bytes())?;
        for (segment, mut records) in by_segment {
            records.sort_by_key(|r| r.0);
            let mut starts = Vec::with_capacity(records.len() + 1);
            let mut cells = Vec::new();
            let mut codes = Vec::new();
            let mut refine = Vec::new();
            for &(_, first, count) in &records {
                starts.push(cells.len() as u32);
                for i in first..first + count {
                    cells.push(cell[i]);
                    let j = place[i] as usize;
                    codes.extend_from_slice(&self.codes[j * m..(j + 1) * m]);
                    refine.extend_from_slice(&self.refine[j * m..(j + 1) * m]);
                }
            }
            starts.push(cells.len() as u32);
            let seg = SegmentCells {
                segment,
                positions: records.iter().map(|r| r.0).collect(),
                starts,
                cells,
                codes,
                refine,
            };
            bincode::serde::encode_into_std_write(&seg, w, config).map_err(enc)?;
        }
        Ok(())
    }

    /// The inverted file of `points` (items from `origins`, in order) from a cache file's bytes
    /// (read from `path`), or `None` when the file is damaged or of another format, or when
    /// the items are too many or too few for its centroids (see [`GROWTH`]). Records the cache
    /// holds keep their cells; the others' items go to their nearest cells.
    pub(crate) fn from_cache(
        path: &Path,
        bytes: &[u8],
        key: u64,
        points: &impl Points,
        d: usize,
        origins: &[Origin],
    ) -> Option<FromCache> {
        // a cache written by another format version (whose payload differs) is rebuilt
        let (_, version) =
            file::check_footer(path, bytes, KIND_SEARCH_CACHE, FORMAT_VERSION, true).ok()?;
        if version != FORMAT_VERSION {
            return None;
        }
        Ivf::from_payload(&bytes[..bytes.len() - FOOTER_LEN], key, points, d, origins)
    }

    /// [`Ivf::from_cache`] on a cache file's payload (its footer and checksum already checked).
    /// Reads the segments' cells, then their codes, one segment at a time, straight into place
    /// (the payload is never decoded whole).
    pub(crate) fn from_payload(
        payload: &[u8],
        key: u64,
        points: &impl Points,
        d: usize,
        origins: &[Origin],
    ) -> Option<FromCache> {
        let (head, mut at): (HeadOwned, usize) = decode_bounded(payload).ok()?;
        let n = points.len();
        let trained = usize::try_from(head.trained).ok()?;
        if head.tag != CACHE_TAG
            || head.d as usize != d
            || n > trained.saturating_mul(GROWTH)
            || n.saturating_mul(GROWTH) < trained
        {
            return None;
        }
        // the centroids alone, to assign the items the cache does not hold
        let centroids = Ivf::from_cells(0, d, head.coarse, head.fine, head.pq, &[], trained)?;
        let m = centroids.pq.bytes();
        // where each live record's items are: (segment, position) -> (first item, items)
        type Wanted = HashMap<((u64, u64, u64), u32), (usize, usize)>;
        let mut wanted = Wanted::with_capacity(origins.len());
        let mut first = 0usize;
        for o in origins {
            wanted.insert((o.segment, o.position), (first, o.components as usize));
            first += o.components as usize;
        }
        if first != n {
            return None;
        }
        let count = u64::from_le_bytes(payload.get(at..at + 8)?.try_into().ok()?);
        at += 8;
        // the records of a decoded segment the cache holds for this snapshot:
        // (first item, first entry in the segment's lists, items)
        let held = |seg: &SegmentCells| -> Option<Vec<(usize, usize, usize)>> {
            let mut out = Vec::new();
            for (i, &pos) in seg.positions.iter().enumerate() {
                let (a, b) = (
                    *seg.starts.get(i)? as usize,
                    *seg.starts.get(i + 1)? as usize,
                );
                if let Some(&(first, items)) = wanted.get(&(seg.segment, pos))
                    && b.checked_sub(a) == Some(items)
                    && b <= seg.cells.len()
                    && b.checked_mul(m).is_some_and(|e| e <= seg.codes.len())
                    && seg.refine.len() == seg.codes.len()
                {
                    out.push((first, a, items));
                }
            }
            Some(out)
        };
        // pass 1: the cells (a cell beyond the centroids' is a damaged cache)
        let cells_total: usize = centroids.fine.iter().map(|f| f.len() / d).sum();
        let mut cell = vec![u32::MAX; n];
        let mut offsets = Vec::new();
        for _ in 0..count {
            offsets.push(at);
            let (seg, used): (SegmentCells, usize) = decode_bounded(payload.get(at..)?).ok()?;
            at += used;
            for (first, a, items) in held(&seg)? {
                let cells = &seg.cells[a..a + items];
                if cells.iter().any(|&c| c as usize >= cells_total) {
                    return None;
                }
                cell[first..first + items].copy_from_slice(cells);
            }
        }
        if at != payload.len() {
            return None;
        }
        let fresh: Vec<u32> = (0..n as u32)
            .filter(|&i| cell[i as usize] == u32::MAX)
            .collect();
        let assigned: Vec<u32> = fresh
            .par_iter()
            .map(|&i| centroids.assign(points.point(i)))
            .collect::<Option<_>>()?;
        for (&i, g) in fresh.iter().zip(assigned) {
            cell[i as usize] = g;
        }
        let mut ivf = Ivf::from_cells(
            n,
            d,
            centroids.coarse,
            centroids.fine,
            centroids.pq,
            &cell,
            trained,
        )?;
        let place = ivf.places();
        // pass 2: the codes, in cell order
        for &off in &offsets {
            let (seg, _): (SegmentCells, usize) = decode_bounded(&payload[off..]).ok()?;
            for (first, a, items) in held(&seg)? {
                for k in 0..items {
                    let j = place[first + k] as usize;
                    ivf.codes[j * m..(j + 1) * m]
                        .copy_from_slice(&seg.codes[(a + k) * m..(a + k + 1) * m]);
                    ivf.refine[j * m..(j + 1) * m]
                        .copy_from_slice(&seg.refine[(a + k) * m..(a + k + 1) * m]);
                }
            }
        }
        let coded: Vec<(usize, Vec<u8>, Vec<u8>)> = fresh
            .par_iter()
            .map(|&i| {
                let p = points.point(i);
                let j = place[i as usize] as usize;
                let c = ivf.fine_centroid(cell[i as usize] as usize)?;
                let r: Vec<f32> = p.iter().zip(c).map(|(v, c)| v - c).collect();
                let (mut first, mut second) = (vec![0u8; m], vec![0u8; m]);
                ivf.pq
                    .encode(cell[i as usize] as usize, &r, &mut first, &mut second);
                Some((j, first, second))
            })
            .collect::<Option<_>>()?;
        for (j, first, second) in coded {
            ivf.codes[j * m..(j + 1) * m].copy_from_slice(&first);
            ivf.refine[j * m..(j + 1) * m].copy_from_slice(&second);
        }
        Some(FromCache {
            ivf,
            exact: head.key == key && fresh.is_empty(),
            assigned: fresh.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ivf::build::Flat;
    use crate::ivf::search::SearchEffort;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `shapes` shapes of `per` components each, in two segments.
    fn origins(shapes: u32, per: u32) -> Vec<Origin> {
        (0..shapes)
            .map(|i| Origin {
                segment: if i < shapes / 2 {
                    (1, 100, 7)
                } else {
                    (2, 200, 9)
                },
                position: i % (shapes / 2),
                components: per,
            })
            .collect()
    }

    /// A cache file gives back the same inverted file; a flipped byte, a truncated file, cells
    /// out of range or too few give none (the reader then builds it).
    #[test]
    fn cache_round_trip_and_damage() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let points: Vec<f32> = (0..5_000 * d).map(|_| rng.random_range(0.0..1.0)).collect();
        let flat = Flat { data: &points, d };
        let ivf = Ivf::build(&flat, d);
        let key = 0x5eed_cafe;
        let path = Path::new("SEARCH-CACHE");
        let origins = origins(500, 10);
        let bytes = ivf.to_cache(key, &origins);
        let back = Ivf::from_cache(path, &bytes, key, &flat, d, &origins).expect("read");
        assert_eq!(back.ivf, ivf);
        assert!(back.exact);
        // the same payload sealed as another format version (version 4 held other fields)
        let payload = bytes[..bytes.len() - FOOTER_LEN].to_vec();
        let (older, _) = file::seal(payload, KIND_SEARCH_CACHE, 4);
        assert!(Ivf::from_cache(path, &older, key, &flat, d, &origins).is_none());
        assert_eq!(back.assigned, 0);
        // another snapshot key: the same cells, but the cache is worth rewriting
        let other = Ivf::from_cache(path, &bytes, key ^ 1, &flat, d, &origins).expect("read");
        assert_eq!(other.ivf, ivf);
        assert!(!other.exact);
        for at in [0, bytes.len() / 3, bytes.len() / 2, bytes.len() - 40] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x5a;
            assert!(
                Ivf::from_cache(path, &bad, key, &flat, d, &origins).is_none(),
                "byte {at}"
            );
        }
        assert!(
            Ivf::from_cache(path, &bytes[..bytes.len() / 2], key, &flat, d, &origins).is_none()
        );
        // well sealed, but a cell beyond the centroids, or more items listed than points
        let seal = |stored: &Stored| {
            let payload = bincode::serde::encode_to_vec(stored, bincode_config()).expect("encode");
            file::seal(payload, KIND_SEARCH_CACHE, FORMAT_VERSION).0
        };
        let stored = Stored {
            tag: CACHE_TAG,
            key,
            d: d as u32,
            trained: 5_000,
            coarse: ivf.coarse.clone(),
            fine: ivf.fine.clone(),
            pq: ivf.pq.clone(),
            segments: vec![SegmentCells {
                segment: (1, 100, 7),
                positions: (0..250).collect(),
                starts: (0..=250).map(|i| i * 10).collect(),
                cells: vec![u32::MAX; 2_500],
                codes: vec![0; 2_500 * ivf.pq.bytes()],
                refine: vec![0; 2_500 * ivf.pq.bytes()],
            }],
        };
        assert!(Ivf::from_cache(path, &seal(&stored), key, &flat, d, &origins).is_none());
        // the cells in range: read; under another layout's tag: rebuilt
        let in_range = Stored {
            segments: vec![SegmentCells {
                cells: vec![0; 2_500],
                ..stored.segments[0].clone()
            }],
            ..stored.clone()
        };
        assert!(Ivf::from_cache(path, &seal(&in_range), key, &flat, d, &origins).is_some());
        let other_layout = Stored {
            tag: CACHE_TAG ^ 1,
            ..in_range
        };
        assert!(Ivf::from_cache(path, &seal(&other_layout), key, &flat, d, &origins).is_none());
        assert!(Ivf::from_cache(path, &bytes, key, &flat, d, &self::origins(501, 10)).is_none());
        // items the cache does not hold, but no fine cell to put them in
        let empty = Stored {
            fine: vec![Vec::new(); ivf.fine.len()],
            segments: Vec::new(),
            ..stored
        };
        assert!(Ivf::from_cache(path, &seal(&empty), key, &flat, d, &origins).is_none());
        // centroids that are not numbers or overflow: the items still get a cell each
        let mut wild = ivf.coarse.clone();
        wild[0] = f32::NAN;
        wild[d] = f32::MAX;
        let odd = Stored {
            coarse: wild,
            fine: ivf.fine.clone(),
            ..empty
        };
        let read = Ivf::from_cache(path, &seal(&odd), key, &flat, d, &origins).expect("read");
        assert_eq!(read.assigned, 5_000);
        assert_eq!(read.ivf.cells().len(), 5_000);
    }

    /// Shapes the cache does not hold go to their nearest cells, and are found; removed ones
    /// are left out; too many new items for the centroids give none.
    #[test]
    fn a_cache_is_extended_with_new_shapes() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        let points: Vec<f32> = (0..6_000 * d).map(|_| rng.random_range(0.0..1.0)).collect();
        let path = Path::new("SEARCH-CACHE");
        // the cache: the first 400 shapes of 10 components
        let old = Flat {
            data: &points[..4_000 * d],
            d,
        };
        let old_origins = origins(400, 10);
        let built = Ivf::build(&old, d);
        let bytes = built.to_cache(1, &old_origins);
        // now: shapes 100..400 of the old segments, and 200 more in a third segment
        let mut now_origins: Vec<Origin> = old_origins[100..].to_vec();
        now_origins.extend((0..200).map(|i| Origin {
            segment: (3, 300, 11),
            position: i,
            components: 10,
        }));
        let now = Flat {
            data: &points[1_000 * d..],
            d,
        };
        let c = Ivf::from_cache(path, &bytes, 2, &now, d, &now_origins).expect("extended");
        assert!(!c.exact);
        assert_eq!(c.assigned, 2_000);
        // the old items keep their cells
        let cells = c.ivf.cells();
        assert_eq!(&cells[..3_000], &built.cells()[1_000..]);
        // every new item is found by its own descriptor
        for i in (3_000..5_000u32).step_by(97) {
            let q = now.point(i);
            // (its residual may lie beyond its cell's ranges: no bound on the distance)
            assert_eq!(c.ivf.search(q, 1, SearchEffort::default())[0].0, i);
        }
        // rewritten for the new snapshot, it reads back exactly
        let again = c.ivf.to_cache(2, &now_origins);
        let back = Ivf::from_cache(path, &again, 2, &now, d, &now_origins).expect("read");
        assert!(back.exact);
        assert_eq!(back.ivf, c.ivf);
        // more than GROWTH times the trained items: built again instead
        let many: Vec<f32> = (0..(GROWTH * 4_000 + 10) * d)
            .map(|_| rng.random_range(0.0..1.0))
            .collect();
        let many_flat = Flat { data: &many, d };
        let many_origins: Vec<Origin> = (0..(GROWTH * 400 + 1) as u32)
            .map(|i| Origin {
                segment: (4, 1, 1),
                position: i,
                components: 10,
            })
            .collect();
        assert!(Ivf::from_cache(path, &bytes, 3, &many_flat, d, &many_origins).is_none());
    }
}
