//! Linear float images and their file formats: PFM (linear RGB), PNG (8-bit
//! sRGB through the core's tone mapping) and raw big-endian Rgb565.

use embedded_graphics::pixelcolor::{Rgb565, Rgb888, RgbColor};
use micropt::Color;
use micropt::film::{FromEncoded, Tile, rgb565_be, tone_map};
use micropt::scene::{MAX_PIXELS, MAX_SIDE};
use std::io::{self, BufRead, Read, Write};
use std::path::Path;

/// A linear RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels.
    pub pixels: Vec<Color>,
}

impl Image {
    /// A black image. The caller bounds the size (the renderers check it
    /// against the scene format's limits, the PFM reader against its own);
    /// the pixel count is computed without overflow.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Color::ZERO; width as usize * height as usize],
        }
    }

    /// The index in `pixels` of (x, y).
    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// The pixel at (x, y).
    pub fn get(&self, x: u32, y: u32) -> Color {
        self.pixels[self.index(x, y)]
    }

    /// Sets the pixel at (x, y).
    pub fn set(&mut self, x: u32, y: u32, c: Color) {
        let i = self.index(x, y);
        self.pixels[i] = c;
    }

    /// The indices in `pixels` of `tile`'s pixels, row-major in the tile.
    pub fn tile_indices(&self, tile: &Tile) -> impl Iterator<Item = usize> + use<> {
        let (width, tile) = (self.width as usize, *tile);
        let w = tile.w.max(1);
        (0..tile.len()).map(move |k| {
            let k = k as u32;
            (tile.y + k / w) as usize * width + (tile.x + k % w) as usize
        })
    }

    /// Writes one tile's pixels (row-major in the tile, `tile.len()` of
    /// them) into the image.
    pub fn put_tile(&mut self, tile: &Tile, px: &[Color]) {
        for (i, c) in self.tile_indices(tile).zip(px) {
            self.pixels[i] = *c;
        }
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> [f64; 3] {
        let n = self.pixels.len().max(1) as f64;
        let mut m = [0.0f64; 3];
        for p in &self.pixels {
            m[0] += f64::from(p.x);
            m[1] += f64::from(p.y);
            m[2] += f64::from(p.z);
        }
        m.map(|v| v / n)
    }

    /// Writes a PFM: "PF", width height, scale -1.0 (little-endian), rows
    /// from bottom to top.
    pub fn write_pfm<W: Write>(&self, mut w: W) -> io::Result<()> {
        write!(w, "PF\n{} {}\n-1.0\n", self.width, self.height)?;
        let mut buf = Vec::with_capacity(self.pixels.len() * 12);
        for y in (0..self.height).rev() {
            for x in 0..self.width {
                let p = self.get(x, y);
                for v in [p.x, p.y, p.z] {
                    buf.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        w.write_all(&buf)
    }

    /// Reads a colour PFM ("PF"), either byte order.
    pub fn read_pfm<R: Read>(r: R) -> io::Result<Self> {
        let bad =
            |m: &str| io::Error::new(io::ErrorKind::InvalidData, format!("not a colour PFM: {m}"));
        let mut r = io::BufReader::new(r);
        let mut header = Vec::new();
        let mut tokens: Vec<String> = Vec::new();
        while tokens.len() < 4 {
            header.clear();
            if r.read_until(b'\n', &mut header)? == 0 {
                return Err(bad("truncated header"));
            }
            let line = std::str::from_utf8(&header).map_err(|_| bad("header is not text"))?;
            tokens.extend(line.split_whitespace().map(str::to_owned));
        }
        if tokens[0] != "PF" {
            return Err(bad("magic is not PF"));
        }
        let width: u32 = tokens[1].parse().map_err(|_| bad("width"))?;
        let height: u32 = tokens[2].parse().map_err(|_| bad("height"))?;
        let scale: f32 = tokens[3].parse().map_err(|_| bad("scale"))?;
        if width == 0 || height == 0 {
            return Err(bad("size (zero width or height)"));
        }
        let pixels = u64::from(width) * u64::from(height);
        if width > MAX_SIDE || height > MAX_SIDE || pixels > u64::from(MAX_PIXELS) {
            return Err(bad(&format!(
                "size {width}x{height} (at most {MAX_SIDE} per side and {MAX_PIXELS} pixels)"
            )));
        }
        // read as the data comes: a header that promises more than the file
        // holds costs no more memory than the file
        let len = pixels * 12;
        let mut data = Vec::new();
        r.take(len).read_to_end(&mut data)?;
        if data.len() as u64 != len {
            return Err(bad("truncated pixel data"));
        }
        let mut img = Image::new(width, height);
        for (i, c) in data.chunks_exact(4).enumerate() {
            let b = [c[0], c[1], c[2], c[3]];
            let v = if scale < 0.0 {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
            let p = i / 3;
            let (x, yb) = ((p as u32) % width, (p as u32) / width);
            let idx = img.index(x, height - 1 - yb);
            let px = &mut img.pixels[idx];
            match i % 3 {
                0 => px.x = v,
                1 => px.y = v,
                _ => px.z = v,
            }
        }
        Ok(img)
    }

    /// 8-bit sRGB bytes (RGB, row-major) through the core's tone mapping.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.pixels.len() * 3);
        for (i, p) in self.pixels.iter().enumerate() {
            let (x, y) = (i as u32 % self.width, i as u32 / self.width);
            let c = Rgb888::from_encoded(tone_map(*p, exposure), x, y);
            out.extend_from_slice(&[c.r(), c.g(), c.b()]);
        }
        out
    }

    /// Writes an 8-bit sRGB PNG.
    pub fn write_png<W: Write>(&self, w: W, exposure: f32) -> io::Result<()> {
        let mut enc = png::Encoder::new(w, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = enc.write_header().map_err(io::Error::other)?;
        writer
            .write_image_data(&self.to_srgb8(exposure))
            .map_err(io::Error::other)?;
        writer.finish().map_err(io::Error::other)
    }

    /// Raw big-endian Rgb565 bytes, ordered-dithered exactly as the firmware
    /// and the panel show them.
    pub fn to_rgb565_be(&self, exposure: f32) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.pixels.len() * 2);
        for (i, p) in self.pixels.iter().enumerate() {
            let (x, y) = (i as u32 % self.width, i as u32 / self.width);
            out.extend_from_slice(&rgb565_be(Rgb565::from_encoded(
                tone_map(*p, exposure),
                x,
                y,
            )));
        }
        out
    }

    /// Writes the image to `path`, choosing the format by extension: `.png`,
    /// `.pfm` or `.rgb565`.
    pub fn save(&self, path: &Path, exposure: f32) -> Result<(), String> {
        let fmt = OutputFormat::from_path(path)?;
        let file = std::fs::File::create(path)
            .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        let mut w = io::BufWriter::new(file);
        let r = match fmt {
            OutputFormat::Png => self.write_png(&mut w, exposure),
            OutputFormat::Pfm => self.write_pfm(&mut w),
            OutputFormat::Rgb565 => w.write_all(&self.to_rgb565_be(exposure)),
        };
        r.and_then(|_| w.flush())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    /// Loads a PFM file.
    pub fn load_pfm(path: &Path) -> Result<Self, String> {
        let f = std::fs::File::open(path)
            .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        Self::read_pfm(f).map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// The output formats the CLI writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    /// 8-bit sRGB PNG.
    Png,
    /// Linear float PFM.
    Pfm,
    /// Raw big-endian Rgb565, dithered (what the firmware dumps).
    Rgb565,
}

impl OutputFormat {
    /// The format of a file name's extension.
    pub fn from_path(path: &Path) -> Result<Self, String> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(Self::Png),
            Some("pfm") => Ok(Self::Pfm),
            Some("rgb565") => Ok(Self::Rgb565),
            _ => Err(format!(
                "unknown output extension in {:?}: use .png, .pfm or .rgb565",
                path.display().to_string()
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_round_trip_is_exact_and_bottom_up() {
        let mut img = Image::new(3, 2);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Color::new(i as f32, -0.5 * i as f32, 1e-3 * i as f32);
        }
        let mut bytes = Vec::new();
        img.write_pfm(&mut bytes).unwrap();
        assert!(bytes.starts_with(b"PF\n3 2\n-1.0\n"));
        // the first stored pixel is the bottom-left one: (0, 1) = index 3
        assert_eq!(&bytes[12..16], &3.0f32.to_le_bytes());
        assert_eq!(Image::read_pfm(&bytes[..]).unwrap(), img);
    }

    /// A header may promise any size: one beyond the renderers' limits is
    /// refused with the limits named, before any allocation; one within them
    /// costs no more memory than the file holds.
    #[test]
    fn hostile_pfm_headers_are_errors() {
        for dims in [
            "32768 32768",
            "4294967295 4294967295",
            "16385 1",
            "16384 16384",
        ] {
            let e = Image::read_pfm(format!("PF\n{dims}\n-1.0\n").as_bytes()).unwrap_err();
            assert!(
                e.to_string()
                    .contains("at most 16384 per side and 33554432 pixels"),
                "{dims}: {e}"
            );
        }
        // the largest size allowed, with no data behind it
        let e = Image::read_pfm(&b"PF\n16384 2048\n-1.0\n"[..]).unwrap_err();
        assert!(e.to_string().contains("truncated pixel data"), "{e}");
        let e = Image::read_pfm(&b"PF\n0 5\n-1.0\n"[..]).unwrap_err();
        assert!(e.to_string().contains("zero width or height"), "{e}");
        let e = Image::read_pfm(&b"PF\n99999999999 5\n-1.0\n"[..]).unwrap_err();
        assert!(e.to_string().contains("width"), "{e}");
    }

    #[test]
    fn extensions() {
        assert_eq!(
            OutputFormat::from_path(Path::new("a.PNG")),
            Ok(OutputFormat::Png)
        );
        assert!(
            OutputFormat::from_path(Path::new("a.jpg"))
                .unwrap_err()
                .contains("unknown output extension")
        );
        assert!(OutputFormat::from_path(Path::new("noext")).is_err());
    }
}
