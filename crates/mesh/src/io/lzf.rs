//! LZF decompression, for PCD's `binary_compressed` data (PCL compresses with Marc Lehmann's
//! liblzf).
//!
//! An LZF stream is a sequence of runs, each opened by a control byte `c`:
//! - `c < 32`: a literal run: the next `c + 1` bytes are copied to the output;
//! - otherwise a back reference: length `L = c >> 5` (when `L = 7`, one more byte is added to
//!   it), then one byte `o`; `L + 2` bytes are copied from `((c & 31) << 8) + o + 1` bytes back in
//!   the output (the copy may overlap itself: a run of repeats).
//!
//! There is no header, no checksum and no end marker: the stream ends with its last byte, and the
//! caller knows the decompressed size (PCD stores it). Every read and every copy is checked: a
//! reference before the start of the output, a run past the end of the input, or output beyond the
//! declared size is an error naming the byte of the compressed data; the output is never larger
//! than the declared size (which the caller has bounded by the input size first).

/// Decompresses `input`, which must give exactly `size` bytes. Errors give the offset in `input`
/// where the data stops making sense, and why.
pub(crate) fn decompress(input: &[u8], size: usize) -> Result<Vec<u8>, (usize, String)> {
    let mut out: Vec<u8> = Vec::with_capacity(size);
    let mut i = 0;
    while i < input.len() {
        let at = i;
        let ctrl = usize::from(input[i]);
        i += 1;
        if ctrl < 32 {
            let n = ctrl + 1;
            let Some(run) = input.get(i..i + n) else {
                return Err((at, format!("a literal run of {n} bytes goes past the end")));
            };
            if out.len() + n > size {
                return Err((
                    at,
                    format!("the data decompresses to more than {size} bytes"),
                ));
            }
            out.extend_from_slice(run);
            i += n;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                let Some(&extra) = input.get(i) else {
                    return Err((at, "a back reference is cut off".into()));
                };
                len += usize::from(extra);
                i += 1;
            }
            let Some(&low) = input.get(i) else {
                return Err((at, "a back reference is cut off".into()));
            };
            i += 1;
            let distance = ((ctrl & 31) << 8) + usize::from(low) + 1;
            let len = len + 2;
            let Some(from) = out.len().checked_sub(distance) else {
                return Err((
                    at,
                    format!(
                        "a back reference points {distance} bytes back, before the start of the \
                         data"
                    ),
                ));
            };
            if out.len() + len > size {
                return Err((
                    at,
                    format!("the data decompresses to more than {size} bytes"),
                ));
            }
            // byte by byte: the source may overlap what this copy writes
            for k in from..from + len {
                let b = out[k];
                out.push(b);
            }
        }
    }
    if out.len() != size {
        return Err((
            input.len(),
            format!(
                "the data decompresses to {} bytes, not the {size} declared",
                out.len()
            ),
        ));
    }
    Ok(out)
}

/// A simple LZF compressor (greedy, exhaustive search of the 8 KiB window), for test fixtures
/// and as the decompressor's oracle.
#[cfg(test)]
pub(crate) fn compress(data: &[u8]) -> Vec<u8> {
    fn flush(out: &mut Vec<u8>, literals: &mut Vec<u8>) {
        for chunk in literals.chunks(32) {
            out.push((chunk.len() - 1) as u8);
            out.extend_from_slice(chunk);
        }
        literals.clear();
    }
    let mut out = Vec::new();
    let mut literals = Vec::new();
    let mut i = 0;
    while i < data.len() {
        let (mut best_len, mut best_distance) = (0, 0);
        for distance in 1..=i.min(8192) {
            let from = i - distance;
            let mut len = 0;
            while len < 264 && i + len < data.len() && data[from + len] == data[i + len] {
                len += 1;
            }
            if len > best_len {
                (best_len, best_distance) = (len, distance);
            }
        }
        if best_len < 3 {
            literals.push(data[i]);
            i += 1;
            continue;
        }
        flush(&mut out, &mut literals);
        let (l, d) = (best_len - 2, best_distance - 1);
        if l < 7 {
            out.push(((l << 5) | (d >> 8)) as u8);
        } else {
            out.push(((7 << 5) | (d >> 8)) as u8);
            out.push((l - 7) as u8);
        }
        out.push((d & 0xFF) as u8);
        i += best_len;
    }
    flush(&mut out, &mut literals);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn hand_made_stream() {
        // "abc" as a literal, then 7 bytes from 3 back (overlapping: "abcabca"), then a long
        // reference (L = 7 + 1: 10 bytes) from 1 back.
        let stream = [2, b'a', b'b', b'c', (5 << 5), 2, (7 << 5), 1, 0];
        assert_eq!(
            decompress(&stream, 20).unwrap(),
            b"abcabcabcaaaaaaaaaaa".to_vec()
        );
    }

    #[test]
    fn round_trips_through_the_test_compressor() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..200 {
            let n = rng.random_range(0..3000);
            let alphabet = 1 + case % 7;
            let data: Vec<u8> = (0..n)
                .map(|_| rng.random_range(0..alphabet as u8))
                .collect();
            let packed = compress(&data);
            assert_eq!(
                decompress(&packed, data.len()).unwrap(),
                data,
                "case {case}"
            );
        }
        // Long runs compress, and the long-reference form is used.
        let zeros = vec![0u8; 10_000];
        let packed = compress(&zeros);
        assert!(packed.len() < 200, "{}", packed.len());
        assert_eq!(decompress(&packed, zeros.len()).unwrap(), zeros);
    }

    #[test]
    fn bad_streams_are_errors_at_their_byte() {
        // a reference before the start
        assert_eq!(decompress(&[0, b'a', (1 << 5), 5], 10).unwrap_err().0, 2);
        // a literal run past the end of the input
        assert_eq!(decompress(&[0, b'a', 4, b'b'], 10).unwrap_err().0, 2);
        // a cut reference
        assert_eq!(decompress(&[0, b'a', (7 << 5)], 10).unwrap_err().0, 2);
        assert_eq!(decompress(&[0, b'a', (1 << 5)], 10).unwrap_err().0, 2);
        // more output than declared, less than declared
        assert_eq!(decompress(&[2, 1, 2, 3], 2).unwrap_err().0, 0);
        assert_eq!(decompress(&[0, 1, (7 << 5), 255, 0], 100).unwrap_err().0, 2);
        assert_eq!(decompress(&[0, 1], 2).unwrap_err().0, 2);
        assert_eq!(decompress(&[], 0).unwrap(), Vec::<u8>::new());
    }
}
