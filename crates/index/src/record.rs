//! What the index stores per shape: [`ShapeRecord`] with its [`ComponentRecord`]s.
//!
//! A shape is identified inside an index by a [`ShapeId`] handed out at add time (never
//! reused), and across adds by its canonical path: adding a record whose canonical path is
//! already indexed with the same [`ContentHash`] is a no-op, with another hash it replaces the
//! old record.

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::Xxh3Default;

use crate::error::{IndexError, Result};

/// Identifier of an indexed shape, unique within one index and never reused (a replaced shape
/// gets a new id).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct ShapeId(pub u64);

impl fmt::Display for ShapeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Hash of a mesh file's bytes: XXH3-128 (seed 0), stored as 16 big-endian bytes so that the
/// hex form reads like the usual `xxh128sum` output.
///
/// It detects changed files; it is not a cryptographic hash.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ContentHash(pub [u8; 16]);

impl ContentHash {
    /// Hash of a byte slice.
    pub fn of_bytes(bytes: &[u8]) -> Self {
        ContentHash(xxhash_rust::xxh3::xxh3_128(bytes).to_be_bytes())
    }

    /// Hash of a file's contents, streamed.
    pub fn of_file(path: &Path) -> Result<Self> {
        let mut f = crate::file::open_regular(path)
            .map_err(|e| IndexError::io("could not open", path, e))?;
        let mut hasher = Xxh3Default::new();
        let mut buf = vec![0u8; 1 << 16];
        loop {
            let n = f
                .read(&mut buf)
                .map_err(|e| IndexError::io("could not read", path, e))?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
        }
        Ok(ContentHash(hasher.digest128().to_be_bytes()))
    }

    /// Lower-case hex, 32 characters.
    pub fn to_hex(&self) -> String {
        self.to_string()
    }
}

impl fmt::Display for ContentHash {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

/// One key-component of an indexed shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComponentRecord<const D: usize> {
    /// The component's descriptor (its meaning belongs to the describe stage). Must be finite.
    #[serde(with = "array_serde")]
    pub descriptor: [f32; D],
    /// Vertex id of the component's geodesic centre in the source mesh.
    pub centre_vertex: u32,
    /// Area of the component divided by the shape's surface area, in [0, 1].
    pub area_fraction: f32,
    /// Number of keypoints in the component's cluster.
    pub keypoint_count: u32,
    /// Position of the centre in the layout's frame and length unit (any translation and
    /// rotation of the whole shape); `None` in records written by format 1 or 2, which did not
    /// store it. Must be finite.
    #[serde(default)]
    pub centre: Option<[f32; 3]>,
}

/// Everything the index stores about one shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeRecord<const D: usize> {
    /// Source path as the user gave it. Must be valid UTF-8.
    pub path: PathBuf,
    /// Canonical (absolute, symlinks resolved) source path; the shape's identity for
    /// skip/replace. See [`canonical_path`]. Must be valid UTF-8.
    pub canonical_path: PathBuf,
    /// Hash of the source file's bytes.
    pub content_hash: ContentHash,
    /// Number of vertices of the surface that was described, whose vertex ids the components
    /// use: the mesh as read, or its canonical surface when the index's profile asks for it.
    pub vertex_count: u32,
    /// Number of faces (triangles) of that surface.
    pub face_count: u32,
    /// Surface area in the file's own units (before normalisation to area 1).
    pub surface_area: f64,
    /// The shape's key-components.
    pub components: Vec<ComponentRecord<D>>,
    /// Pairwise geodesic distances between component centres, row-major m×m with
    /// m = `components.len()`, in normalised units (shape area 1). Finite.
    pub layout: Vec<f32>,
    /// Points uniform by area on the described surface, in the frame and length unit of the
    /// components' centres (for geometric verification); empty in records written by formats
    /// 1 to 3, which did not store it. At most [`MAX_SAMPLE_POINTS`], finite.
    #[serde(default)]
    pub sample: Vec<[f32; 3]>,
    /// Vertices on the mesh's boundary: 0 for a closed surface, more for a fragment or a scan
    /// (0 in records written by formats 1 to 3, which did not store it).
    #[serde(default)]
    pub boundary_vertices: u32,
}

/// Most points a record's [`ShapeRecord::sample`] may hold.
pub const MAX_SAMPLE_POINTS: usize = 4096;

impl<const D: usize> ShapeRecord<D> {
    /// Layout distance between components `i` and `j`, if both exist.
    pub fn layout_distance(&self, i: usize, j: usize) -> Option<f32> {
        let m = self.components.len();
        if i < m && j < m {
            self.layout.get(i * m + j).copied()
        } else {
            None
        }
    }

    /// Checks that the record can be stored: UTF-8 paths, finite numbers, a non-empty mesh,
    /// component keypoint counts within the mesh's vertex count and area fractions in [0, 1],
    /// an m×m layout. (The centre vertex is not checked against the vertex count: indexes of
    /// format 1 hold synthetic records that break that rule, and readers check it where they use
    /// it.)
    pub fn validate(&self) -> Result<()> {
        let bad = |reason: String| IndexError::InvalidRecord {
            path: self.path.clone(),
            reason,
        };
        if self.path.to_str().is_none() || self.canonical_path.to_str().is_none() {
            return Err(bad("the path is not valid UTF-8".into()));
        }
        if self.canonical_path.as_os_str().is_empty() {
            return Err(bad("the canonical path is empty".into()));
        }
        if !self.surface_area.is_finite() || self.surface_area < 0.0 {
            return Err(bad(format!(
                "surface area {} is not a finite non-negative number",
                self.surface_area
            )));
        }
        if self.vertex_count == 0 || self.face_count == 0 {
            return Err(bad(format!(
                "a mesh of {} vertices and {} faces",
                self.vertex_count, self.face_count
            )));
        }
        let m = self.components.len();
        if u32::try_from(m).is_err() {
            return Err(bad(format!("{m} components are too many")));
        }
        if self.layout.len() != m * m {
            return Err(bad(format!(
                "the layout has {} values, {m} components need {m}×{m} = {}",
                self.layout.len(),
                m * m
            )));
        }
        if let Some(i) = self.layout.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("layout value {i} is not finite")));
        }
        if self.boundary_vertices > self.vertex_count {
            return Err(bad(format!(
                "{} boundary vertices, the mesh {} vertices",
                self.boundary_vertices, self.vertex_count
            )));
        }
        if self.sample.len() > MAX_SAMPLE_POINTS {
            return Err(bad(format!(
                "a surface sample of {} points (at most {MAX_SAMPLE_POINTS})",
                self.sample.len()
            )));
        }
        if let Some(i) = self
            .sample
            .iter()
            .position(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(bad(format!("surface sample point {i} is not finite")));
        }
        for (c, comp) in self.components.iter().enumerate() {
            if let Some(i) = comp.descriptor.iter().position(|v| !v.is_finite()) {
                return Err(bad(format!(
                    "descriptor value {i} of component {c} is not finite"
                )));
            }
            if !(0.0..=AREA_FRACTION_MAX).contains(&comp.area_fraction) {
                return Err(bad(format!(
                    "area fraction {} of component {c} is not between 0 and 1",
                    comp.area_fraction
                )));
            }
            if let Some(p) = comp.centre
                && !p.iter().all(|v| v.is_finite())
            {
                return Err(bad(format!(
                    "the centre position of component {c} is not finite"
                )));
            }
            if comp.keypoint_count > self.vertex_count {
                return Err(bad(format!(
                    "component {c} has {} keypoints, the mesh {} vertices",
                    comp.keypoint_count, self.vertex_count
                )));
            }
        }
        Ok(())
    }
}

/// The largest area fraction a record may hold: a part is at most the whole surface, plus room
/// for rounding in the sum of its triangle areas.
const AREA_FRACTION_MAX: f32 = 1.0 + 1e-3;

/// The canonical form of a source path used as a shape's identity: `fs::canonicalize` when the
/// file exists; for a file that no longer exists (e.g. when removing it from the index), its
/// canonicalised parent directory joined with its file name; otherwise the path made absolute
/// against the current directory.
pub fn canonical_path(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    if let (Some(parent), Some(name)) = (abs.parent(), abs.file_name())
        && let Ok(p) = std::fs::canonicalize(parent)
    {
        return p.join(name);
    }
    abs
}

/// Serde for `[f32; D]` with a const generic `D` (serde itself only covers lengths ≤ 32):
/// a tuple of `D` floats, which bincode writes as `D` little-endian `f32`s with no length.
pub(crate) mod array_serde {
    use std::fmt;
    use std::marker::PhantomData;

    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer, const D: usize>(v: &[f32; D], s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(D)?;
        for x in v {
            t.serialize_element(x)?;
        }
        t.end()
    }

    struct ArrayVisitor<const D: usize>(PhantomData<[f32; D]>);

    impl<'de, const D: usize> Visitor<'de> for ArrayVisitor<D> {
        type Value = [f32; D];

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            write!(f, "an array of {D} f32")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[f32; D], A::Error> {
            let mut out = [0f32; D];
            for (i, slot) in out.iter_mut().enumerate() {
                *slot = seq
                    .next_element()?
                    .ok_or_else(|| A::Error::invalid_length(i, &self))?;
            }
            Ok(out)
        }
    }

    pub fn deserialize<'de, De: Deserializer<'de>, const D: usize>(
        d: De,
    ) -> Result<[f32; D], De::Error> {
        d.deserialize_tuple(D, ArrayVisitor::<D>(PhantomData))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_hex_is_32_chars_and_stable() {
        let h = ContentHash::of_bytes(b"abc");
        assert_eq!(h.to_hex().len(), 32);
        assert_eq!(h, ContentHash::of_bytes(b"abc"));
        assert_ne!(h, ContentHash::of_bytes(b"abd"));
    }

    #[test]
    fn file_hash_equals_bytes_hash() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.off");
        let data: Vec<u8> = (0..200_000u32).map(|i| (i * 7 % 251) as u8).collect();
        std::fs::write(&p, &data).unwrap();
        assert_eq!(
            ContentHash::of_file(&p).unwrap(),
            ContentHash::of_bytes(&data)
        );
    }

    #[test]
    fn validate_rejects_bad_layout_and_nan() {
        let mut r = crate::synthetic::record::<4>(1, 3);
        assert!(r.validate().is_ok());
        r.layout.pop();
        assert!(matches!(
            r.validate(),
            Err(IndexError::InvalidRecord { .. })
        ));
        let mut r = crate::synthetic::record::<4>(1, 3);
        r.components[1].descriptor[2] = f32::NAN;
        let e = r.validate().unwrap_err();
        assert!(e.to_string().contains("component 1"), "{e}");
    }
}
