//! Tiles, tone mapping, dithering, and output to embedded-graphics.
//!
//! Tone mapping is deliberately simple and documented: multiply the linear
//! radiance by the exposure, clamp to [0, 1], and apply the sRGB transfer
//! curve (IEC 61966-2-1: `12.92 v` below 0.0031308, else
//! `1.055 v^(1/2.4) − 0.055`). No filmic curve: a pixel of radiance 0.5
//! shows as sRGB 0.5 in linear light, which keeps the furnace test and the
//! reference comparisons readable. The same function feeds the host's PNGs
//! and the board's panel.
//!
//! Rgb565 output is ordered-dithered with an 8×8 Bayer matrix indexed by the
//! pixel's absolute image coordinates, so tiles join without seams and the
//! result does not depend on the tile size.

use crate::geometry::Color;
use crate::math;
use embedded_graphics::pixelcolor::{Rgb565, Rgb888};
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::Rectangle;

/// Side of the square tiles the renderer works in (a tile is at most
/// `TILE × TILE` pixels; edge tiles are smaller).
pub const TILE: u32 = 16;

/// A rectangle of the image, rendered as a unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width in pixels (1..=TILE for tiles from [`tiles`]).
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
}

impl Tile {
    /// Number of pixels (saturating: a tile made by hand may be of any
    /// size, the product of two `u32`s is counted without overflow).
    pub fn len(&self) -> usize {
        usize::try_from(u64::from(self.w) * u64::from(self.h)).unwrap_or(usize::MAX)
    }

    /// Whether the tile has no pixels.
    pub fn is_empty(&self) -> bool {
        self.w == 0 || self.h == 0
    }

    /// The embedded-graphics rectangle of this tile.
    pub fn rectangle(&self) -> Rectangle {
        Rectangle::new(
            Point::new(self.x as i32, self.y as i32),
            Size::new(self.w, self.h),
        )
    }
}

/// Number of tiles of a `width × height` image (for any `u32` sizes: counted
/// in 64 bits, saturating at `usize::MAX` on a 32-bit target).
pub const fn tile_count(width: u32, height: u32) -> usize {
    let n = width.div_ceil(TILE) as u64 * height.div_ceil(TILE) as u64;
    if n > usize::MAX as u64 {
        usize::MAX
    } else {
        n as usize
    }
}

/// Tile number `i` (row-major) of a `width × height` image, or `None`.
pub fn tile_at(width: u32, height: u32, i: usize) -> Option<Tile> {
    let tx = width.div_ceil(TILE) as usize;
    if tx == 0 || i >= tile_count(width, height) {
        return None;
    }
    // i < tiles: the tile's column and row are below width / TILE and
    // height / TILE rounded up, so x < width and y < height
    let x = (i % tx) as u32 * TILE;
    let y = u32::try_from(i / tx).ok()?.checked_mul(TILE)?;
    Some(Tile {
        x,
        y,
        w: width.saturating_sub(x).min(TILE),
        h: height.saturating_sub(y).min(TILE),
    })
}

/// The tiles of a `width × height` image in row-major order, each at most
/// [`TILE`] × [`TILE`].
pub fn tiles(width: u32, height: u32) -> impl Iterator<Item = Tile> + Clone {
    (0..tile_count(width, height)).filter_map(move |i| tile_at(width, height, i))
}

/// The sRGB transfer curve (linear [0, 1] → encoded [0, 1]).
#[inline]
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else if v >= 1.0 {
        1.0
    } else {
        1.055 * math::srgb_power(v) - 0.055
    }
}

/// Tone mapping: exposure, clamp to [0, 1], sRGB curve. Returns encoded
/// values in [0, 1]; NaN maps to 0.
#[inline]
pub fn tone_map(c: Color, exposure: f32) -> [f32; 3] {
    let f = |v: f32| srgb_encode(math::clamp(v * exposure, 0.0, 1.0));
    [f(c.x), f(c.y), f(c.z)]
}

/// Ordered-dither threshold in (0, 1) for pixel (x, y): the 8×8 Bayer matrix.
#[inline]
pub fn bayer8(x: u32, y: u32) -> f32 {
    // bit-interleave of (x ^ y, y) reversed: the recursive Bayer index
    let a = x ^ y;
    let b = y;
    let i = ((a & 1) << 5)
        | ((b & 1) << 4)
        | ((a & 2) << 2)
        | ((b & 2) << 1)
        | ((a & 4) >> 1)
        | ((b & 4) >> 2);
    (i as f32 + 0.5) / 64.0
}

/// Quantises an encoded value in [0, 1] to `0..=max` with threshold `t`.
#[inline(always)]
fn quantize(v: f32, max: u32, t: f32) -> u8 {
    let q = math::floor(v * max as f32 + t);
    math::clamp(q, 0.0, max as f32) as u8
}

/// Conversion from a tone-mapped (sRGB-encoded, [0, 1]) value to a display
/// colour at image position (x, y).
pub trait FromEncoded: PixelColor {
    /// The display colour of encoded `rgb` at pixel (x, y).
    fn from_encoded(rgb: [f32; 3], x: u32, y: u32) -> Self;
}

impl FromEncoded for Rgb565 {
    /// Ordered dithering to 5/6/5 bits.
    #[inline]
    fn from_encoded(rgb: [f32; 3], x: u32, y: u32) -> Self {
        let t = bayer8(x, y);
        Rgb565::new(
            quantize(rgb[0], 31, t),
            quantize(rgb[1], 63, t),
            quantize(rgb[2], 31, t),
        )
    }
}

impl FromEncoded for Rgb888 {
    /// Rounding to 8 bits (no dithering).
    #[inline]
    fn from_encoded(rgb: [f32; 3], _x: u32, _y: u32) -> Self {
        Rgb888::new(
            quantize(rgb[0], 255, 0.5),
            quantize(rgb[1], 255, 0.5),
            quantize(rgb[2], 255, 0.5),
        )
    }
}

/// Draws one tile of linear radiance (`pixels`, row-major, `tile.len()`
/// values) into any embedded-graphics target, tone-mapped with `exposure`,
/// through one `fill_contiguous` call.
///
/// ```
/// use embedded_graphics::{mock_display::MockDisplay, pixelcolor::Rgb565, prelude::*};
/// use micropt::film::{draw_tile, Tile};
/// use micropt::Vec3;
/// let mut display: MockDisplay<Rgb565> = MockDisplay::new();
/// let tile = Tile { x: 1, y: 0, w: 2, h: 1 };
/// draw_tile(&mut display, &tile, &[Vec3::ONE, Vec3::ZERO], 1.0).unwrap();
/// assert_eq!(display.get_pixel(Point::new(1, 0)), Some(Rgb565::WHITE));
/// assert_eq!(display.get_pixel(Point::new(2, 0)), Some(Rgb565::BLACK));
/// ```
pub fn draw_tile<D>(
    target: &mut D,
    tile: &Tile,
    pixels: &[Color],
    exposure: f32,
) -> Result<(), D::Error>
where
    D: DrawTarget,
    D::Color: FromEncoded,
{
    draw_tile_iter(target, tile, pixels.iter().copied(), exposure)
}

/// [`draw_tile`] from an iterator of linear radiance (row-major, the first
/// `tile.len()` values are drawn): lets a caller compute pixels as they are
/// drawn instead of holding a tile buffer.
pub fn draw_tile_iter<D>(
    target: &mut D,
    tile: &Tile,
    pixels: impl Iterator<Item = Color>,
    exposure: f32,
) -> Result<(), D::Error>
where
    D: DrawTarget,
    D::Color: FromEncoded,
{
    let w = tile.w.max(1);
    let colors = pixels.take(tile.len()).enumerate().map(|(i, c)| {
        let i = i as u32;
        let (x, y) = (tile.x.saturating_add(i % w), tile.y.saturating_add(i / w));
        D::Color::from_encoded(tone_map(c, exposure), x, y)
    });
    target.fill_contiguous(&tile.rectangle(), colors)
}

/// The raw big-endian Rgb565 value of a colour (the byte order of an SPI
/// panel and of the firmware's dump).
pub fn rgb565_be(c: Rgb565) -> [u8; 2] {
    c.into_storage().to_be_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_graphics::mock_display::MockDisplay;

    #[test]
    fn tiles_cover_the_image_once() {
        let mut count = [0u8; 40 * 21];
        for t in tiles(40, 21) {
            assert!(t.w <= TILE && t.h <= TILE && !t.is_empty());
            for y in t.y..t.y + t.h {
                for x in t.x..t.x + t.w {
                    count[(y * 40 + x) as usize] += 1;
                }
            }
        }
        assert!(count.iter().all(|&c| c == 1));
    }

    #[test]
    fn tile_arithmetic_does_not_overflow() {
        // 2^28 x 2^28 tiles: more than a u32 counts
        let big = u32::MAX;
        assert_eq!(tile_count(big, big) as u64, 1u64 << 56);
        assert_eq!(tile_count(big, 1), 1 << 28);
        let last = tile_at(big, 1, (1 << 28) - 1).unwrap();
        assert_eq!((last.x, last.w, last.h), (big - 15, 15, 1));
        assert_eq!(tile_at(big, 1, 1 << 28), None);
        // a tile made by hand may be of any size
        let t = Tile {
            x: big,
            y: big,
            w: big,
            h: big,
        };
        assert_eq!(
            t.len() as u64,
            (u64::from(big) * u64::from(big)).min(usize::MAX as u64)
        );
        assert!(!t.is_empty());
        // drawn at the edge of the coordinate space: no overflow
        let mut d: MockDisplay<Rgb888> = MockDisplay::new();
        d.set_allow_out_of_bounds_drawing(true);
        let edge = Tile {
            x: big - 1,
            y: big - 1,
            w: 2,
            h: 2,
        };
        let _ = draw_tile(&mut d, &edge, &[Color::ONE; 4], 1.0);
    }

    #[test]
    fn tone_map_known_values() {
        assert_eq!(tone_map(Color::ZERO, 1.0), [0.0; 3]);
        assert_eq!(tone_map(Color::ONE, 1.0), [1.0; 3]);
        assert_eq!(tone_map(Color::splat(7.0), 1.0), [1.0; 3]);
        // linear 0.5 encodes to 0.735357 (IEC 61966-2-1)
        let v = tone_map(Color::splat(0.25), 2.0)[0];
        assert!(math::abs(v - 0.735_357) < 2e-6, "{v}");
        // linear segment
        assert!(math::abs(srgb_encode(0.002) - 0.025_84) < 1e-6);
        assert_eq!(
            tone_map(Color::new(f32::NAN, -1.0, f32::INFINITY), 1.0),
            [0.0, 0.0, 1.0]
        );
    }

    #[test]
    fn bayer_is_a_permutation_with_mean_one_half() {
        let mut seen = [false; 64];
        let mut sum = 0.0;
        for y in 0..8 {
            for x in 0..8 {
                let t = bayer8(x, y);
                let i = (t * 64.0 - 0.5) as usize;
                assert!(!seen[i]);
                seen[i] = true;
                sum += t;
            }
        }
        assert_eq!(sum / 64.0, 0.5);
        assert_eq!(bayer8(0, 0), bayer8(8, 16));
    }

    #[test]
    fn rgb565_dither_averages_to_the_input() {
        // encoded 0.5 lies between levels 15 and 16 of 31: half of the 64
        // positions of the Bayer tile round up
        let mut sum = 0u32;
        for y in 0..8 {
            for x in 0..8 {
                sum += u32::from(Rgb565::from_encoded([0.5; 3], x, y).r());
            }
        }
        assert_eq!(sum, 15 * 32 + 16 * 32);
        assert_eq!(Rgb565::from_encoded([1.0; 3], 3, 5), Rgb565::WHITE);
        assert_eq!(Rgb565::from_encoded([0.0; 3], 3, 5), Rgb565::BLACK);
        assert_eq!(
            Rgb888::from_encoded([0.5; 3], 0, 0),
            Rgb888::new(128, 128, 128)
        );
    }

    #[test]
    fn draw_tile_pixel_by_pixel() {
        let mut d: MockDisplay<Rgb888> = MockDisplay::new();
        let tile = Tile {
            x: 2,
            y: 1,
            w: 3,
            h: 2,
        };
        let px = [
            Color::ONE,
            Color::ZERO,
            Color::new(1.0, 1.0, 0.0),
            Color::new(1.0, 0.0, 0.0),
            Color::new(0.0, 1.0, 0.0),
            Color::new(0.0, 0.0, 1.0),
        ];
        draw_tile(&mut d, &tile, &px, 1.0).unwrap();
        d.assert_pattern(&["     ", "  WKY", "  RGB"]);
        // a grey: linear 0.5 encodes to sRGB 0.735357 -> 187.52 -> 188
        let mut g: MockDisplay<Rgb888> = MockDisplay::new();
        draw_tile(
            &mut g,
            &Tile {
                x: 0,
                y: 0,
                w: 1,
                h: 1,
            },
            &[Color::splat(0.5)],
            1.0,
        )
        .unwrap();
        assert_eq!(g.get_pixel(Point::zero()), Some(Rgb888::new(188, 188, 188)));
    }
}
