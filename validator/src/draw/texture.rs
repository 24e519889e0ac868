//! Alpha textures under a BLAS geometry's picture, as the NVIDIA OMM SDK's
//! debug images draw a bake over its alpha texture: a PNG read with the
//! `png` crate (the one resvg already brings), bounded before anything
//! sized by its header is allocated, and reduced to a grid of at most
//! [`MAX_CELLS`] × [`MAX_CELLS`] cells, each the mean alpha of the texels
//! it covers.

use std::io::Cursor;
use std::path::Path;

/// The most texels a texture may have: 2^24, a 4096 × 4096 texture, whose
/// decoded RGBA8 image takes 64 MiB.
pub const MAX_TEXELS: u64 = 1 << 24;
/// The largest PNG file read (a 4096 × 4096 RGBA PNG that does not
/// compress is 64 MiB).
pub const MAX_FILE_BYTES: u64 = 80 << 20;
/// The most cells across and down the drawn grid.
pub const MAX_CELLS: u32 = 256;
/// The decoder's own bound on what it allocates besides the image.
const DECODER_BYTES: usize = 16 << 20;

/// A texture's alpha, reduced to the grid a picture draws.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AlphaGrid {
    /// The PNG's size in texels.
    pub width: u32,
    pub height: u32,
    /// The grid's size in cells.
    pub cols: u32,
    pub rows: u32,
    /// Mean alpha per cell (0 transparent, 255 opaque), row by row from the
    /// image's top.
    pub alpha: Vec<u8>,
    /// Where the alpha came from: `alpha channel`, `grey` or `red channel`.
    pub channel: &'static str,
}

/// Reads the PNG at `path`.
pub fn load(path: &Path) -> Result<AlphaGrid, String> {
    let shown = path.display();
    let len = std::fs::metadata(path)
        .map_err(|e| format!("{shown}: cannot read it: {e}"))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(format!(
            "{shown}: {len} bytes; an alpha texture may have at most {MAX_FILE_BYTES}"
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| format!("{shown}: cannot read it: {e}"))?;
    decode(&bytes).map_err(|e| format!("{shown}: {e}"))
}

/// The width and height in a PNG's header (its first chunk, IHDR, which
/// the format requires first), read before any decoder sees the file.
fn header_size(bytes: &[u8]) -> Result<(u32, u32), String> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    let be = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    };
    if !bytes.starts_with(SIGNATURE) || bytes.get(12..16) != Some(b"IHDR") {
        return Err("not a PNG file (no PNG signature and header)".into());
    }
    match (be(16), be(20)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err("the PNG header is cut short".into()),
    }
}

/// Decodes a PNG and reduces its alpha to the grid.
pub fn decode(bytes: &[u8]) -> Result<AlphaGrid, String> {
    let (width, height) = header_size(bytes)?;
    let texels = u64::from(width) * u64::from(height);
    if texels == 0 || texels > MAX_TEXELS {
        return Err(format!(
            "{width} x {height} texels; an alpha texture may have 1 to {MAX_TEXELS} (4096 x 4096)"
        ));
    }
    let mut decoder = png::Decoder::new_with_limits(
        Cursor::new(bytes),
        png::Limits {
            bytes: DECODER_BYTES,
        },
    );
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder
        .read_info()
        .map_err(|e| format!("cannot decode the PNG: {e}"))?;
    let (color, _) = reader.output_color_type();
    let (channels, channel, at) = match color {
        png::ColorType::Grayscale => (1, "grey", 0),
        png::ColorType::GrayscaleAlpha => (2, "alpha channel", 1),
        png::ColorType::Rgb => (3, "red channel", 0),
        png::ColorType::Rgba => (4, "alpha channel", 3),
        // normalize_to_color8 expands palettes.
        png::ColorType::Indexed => return Err("a palette PNG that did not expand".into()),
    };
    // The header was bounded above: at most 4 bytes a texel, 64 MiB.
    let size = reader
        .output_buffer_size()
        .filter(|size| *size as u64 <= MAX_TEXELS * 4)
        .ok_or("the decoded image would exceed 64 MiB")?;
    let mut image = vec![0u8; size];
    let frame = reader
        .next_frame(&mut image)
        .map_err(|e| format!("cannot decode the PNG: {e}"))?;
    let stride = frame.line_size;
    let cols = width.min(MAX_CELLS);
    let rows = height.min(MAX_CELLS);
    let mut alpha = Vec::with_capacity((cols * rows) as usize);
    // Cell (c, r) covers texels [c·width/cols, (c+1)·width/cols) across
    // and likewise down: every texel in exactly one cell.
    let span = |i: u32, n: u32, of: u32| {
        let start = u64::from(i) * u64::from(of) / u64::from(n);
        let end = (u64::from(i) + 1) * u64::from(of) / u64::from(n);
        start as usize..end as usize
    };
    for r in 0..rows {
        for c in 0..cols {
            let (xs, ys) = (span(c, cols, width), span(r, rows, height));
            let mut sum = 0u64;
            for y in ys.clone() {
                let line = image.get(y * stride..).unwrap_or(&[]);
                for x in xs.clone() {
                    sum += u64::from(line.get(x * channels + at).copied().unwrap_or(0));
                }
            }
            let n = (xs.len() * ys.len()).max(1) as u64;
            alpha.push(((sum + n / 2) / n) as u8);
        }
    }
    Ok(AlphaGrid {
        width,
        height,
        cols,
        rows,
        alpha,
        channel,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `width` × `height` grey+alpha texels with alpha `a(x, y)`.
    pub(crate) fn png_of(width: u32, height: u32, a: impl Fn(u32, u32) -> u8) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut out, width, height);
            encoder.set_color(png::ColorType::GrayscaleAlpha);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header().unwrap();
            let mut data = Vec::new();
            for y in 0..height {
                for x in 0..width {
                    data.extend([128, a(x, y)]);
                }
            }
            writer.write_image_data(&data).unwrap();
        }
        out
    }

    #[test]
    fn the_grid_holds_the_mean_alpha_of_each_cell() {
        // 512 × 2 texels: two texels to a cell across, one down.
        let png = png_of(512, 2, |x, y| if x % 2 == 0 && y == 0 { 255 } else { 0 });
        let grid = decode(&png).unwrap();
        assert_eq!(
            (grid.cols, grid.rows, grid.channel),
            (256, 2, "alpha channel")
        );
        assert_eq!(grid.alpha[0], 128);
        assert_eq!(grid.alpha[256], 0);
    }

    #[test]
    fn a_hostile_header_is_refused_before_anything_is_allocated() {
        // A valid 1 × 1 PNG whose header then claims 65535 × 65535 texels
        // (16 GiB of RGBA): refused from the header alone.
        let mut png = png_of(1, 1, |_, _| 255);
        png[16..20].copy_from_slice(&65_535u32.to_be_bytes());
        png[20..24].copy_from_slice(&65_535u32.to_be_bytes());
        let error = decode(&png).unwrap_err();
        assert!(error.contains("65535 x 65535 texels"), "{error}");
        assert!(decode(b"GIF89a").unwrap_err().contains("not a PNG"));
        assert!(decode(&png[..18]).unwrap_err().contains("cut short"));
        // A header within bounds with no image data after it: an error.
        let truncated = &png_of(4, 4, |_, _| 0)[..40];
        assert!(decode(truncated).is_err());
    }
}
