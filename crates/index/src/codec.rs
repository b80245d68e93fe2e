//! The encoding every index payload shares: bincode 2 with fixed-width little-endian integers
//! (the manifest, segment heads and records, the search cache), decoded with a limit from the
//! payload's own size so that a crafted length field is an error rather than a huge
//! allocation; and the little-endian fields of the fixed-width parts (footers, segment tables).

/// The bincode configuration of every index payload: little endian, fixed-width integers.
pub(crate) fn bincode_config() -> bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Fixint,
    bincode::config::NoLimit,
> {
    bincode::config::standard()
        .with_little_endian()
        .with_fixed_int_encoding()
}

/// Decodes a `T` from the start of `bytes` with the index's encoding, never allocating much
/// more than `bytes` holds.
///
/// A length field inside the bytes (of a string, a path, a vector) is trusted by bincode up to
/// its configured limit, and every decoded byte counts against that limit. The limit here is the
/// smallest power of 16 (from 64 KiB) not below `bytes.len()`, so a crafted length fails with
/// "limit exceeded" instead of an allocation of terabytes, and no honest payload, whose decoded
/// bytes never exceed its own length, is refused.
pub(crate) fn decode_bounded<T: serde::de::DeserializeOwned>(
    bytes: &[u8],
) -> std::result::Result<(T, usize), bincode::error::DecodeError> {
    macro_rules! limited {
        ($limit:expr) => {
            bincode::serde::decode_from_slice(bytes, bincode_config().with_limit::<{ $limit }>())
        };
    }
    match bytes.len() as u64 {
        n if n <= 1 << 16 => limited!(1 << 16),
        n if n <= 1 << 20 => limited!(1 << 20),
        n if n <= 1 << 24 => limited!(1 << 24),
        n if n <= 1 << 28 => limited!(1 << 28),
        n if n <= 1 << 32 => limited!(1 << 32),
        n if n <= 1 << 36 => limited!(1 << 36),
        _ => limited!(1 << 40),
    }
}

/// The little-endian `u64` at the start of `b` (at least 8 bytes).
pub(crate) fn le_u64(b: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[..8]);
    u64::from_le_bytes(a)
}

/// The little-endian `u32` at the start of `b` (at least 4 bytes).
pub(crate) fn le_u32(b: &[u8]) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[..4]);
    u32::from_le_bytes(a)
}

/// Writes `v` little endian at `out[at..at + 8]`.
pub(crate) fn put_u64(out: &mut [u8], at: usize, v: u64) {
    out[at..at + 8].copy_from_slice(&v.to_le_bytes());
}
