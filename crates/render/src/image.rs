//! An RGBA image and its PNG encoding (8-bit sRGB; RGB when fully opaque, RGBA otherwise),
//! written atomically (temporary file in the same directory, `sync_data`, rename).

use std::io::Write;
use std::path::Path;

use crate::error::RenderError;

/// An 8-bit sRGB image with straight (not premultiplied) alpha, rows top to bottom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<[u8; 4]>,
}

impl Image {
    /// An image of the given size filled with one colour.
    pub fn new(width: u32, height: u32, fill: [u8; 4]) -> Image {
        Image {
            width,
            height,
            pixels: vec![fill; width as usize * height as usize],
        }
    }

    /// Builds an image from row-major pixels; `None` unless `pixels.len() == width × height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<[u8; 4]>) -> Option<Image> {
        (pixels.len() == width as usize * height as usize).then_some(Image {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixel at column `x`, row `y` (row 0 at the top), or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        (x < self.width && y < self.height)
            .then(|| self.pixels[y as usize * self.width as usize + x as usize])
    }

    /// All pixels, row-major from the top-left corner.
    pub fn pixels(&self) -> &[[u8; 4]] {
        &self.pixels
    }

    /// Whether every pixel has alpha 255.
    pub fn is_opaque(&self) -> bool {
        self.pixels.iter().all(|p| p[3] == 255)
    }

    /// Encodes the image as PNG: 8-bit RGB when it is fully opaque, 8-bit RGBA otherwise. The
    /// bytes depend only on the pixels (no timestamps), so equal images give equal files.
    pub fn to_png_bytes(&self) -> Result<Vec<u8>, RenderError> {
        let mut out = Vec::new();
        self.encode(&mut out)?;
        Ok(out)
    }

    /// Writes the image as a PNG file (see [`Image::to_png_bytes`]) through
    /// [`keycomp_mesh::io::output::Output`]: atomically (a temporary file in the same folder,
    /// synced, renamed over `path`, so readers never see a half-written file), following
    /// symbolic links, writing a FIFO or device in place and refusing a directory.
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        let bytes = self.to_png_bytes()?;
        keycomp_mesh::io::output::write_file(path, |w| w.write_all(&bytes)).map_err(|source| {
            RenderError::Io {
                path: path.to_path_buf(),
                source,
            }
        })
    }

    fn encode<W: Write>(&self, w: W) -> Result<(), RenderError> {
        let enc_err = |e: png::EncodingError| RenderError::Encode {
            message: e.to_string(),
        };
        let mut enc = png::Encoder::new(w, self.width, self.height);
        let opaque = self.is_opaque();
        enc.set_color(if opaque {
            png::ColorType::Rgb
        } else {
            png::ColorType::Rgba
        });
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        let mut writer = enc.write_header().map_err(enc_err)?;
        let data: Vec<u8> = if opaque {
            self.pixels
                .iter()
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect()
        } else {
            self.pixels.iter().flatten().copied().collect()
        };
        writer.write_image_data(&data).map_err(enc_err)?;
        writer.finish().map_err(enc_err)
    }
}
