//! The Pico's image on the Display Pack 2.0 at half its size, each pixel
//! drawn as a 2 × 2 block (feature `pack-20`).

use embedded_graphics::Pixel;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::{OriginDimensions, Point, Size};
use embedded_graphics::primitives::{PointsIter, Rectangle};

/// An image of half the panel's width and height drawn at twice its size
/// (each pixel a 2 × 2 block): the RP2040's RAM holds the denoiser's rings
/// for 160 columns beside the demo's scenes, not for 320.
pub struct Doubled<D>(pub D);

/// The widest row [`Doubled`] draws in one call.
const DOUBLED_ROW: usize = 320;

impl<D: OriginDimensions> OriginDimensions for Doubled<D> {
    fn size(&self) -> Size {
        let s = self.0.size();
        Size::new(s.width / 2, s.height / 2)
    }
}

impl<D: DrawTarget + OriginDimensions> DrawTarget for Doubled<D> {
    type Color = D::Color;
    type Error = D::Error;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        for Pixel(p, c) in pixels {
            let block = Rectangle::new(p * 2, Size::new(2, 2));
            self.0.fill_solid(&block, c)?;
        }
        Ok(())
    }

    fn fill_contiguous<I>(&mut self, area: &Rectangle, colors: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Self::Color>,
    {
        // a row (what the demo draws): doubled once, written twice
        if area.size.height == 1 && area.size.width as usize * 2 <= DOUBLED_ROW {
            let mut row: heapless::Vec<Self::Color, DOUBLED_ROW> = heapless::Vec::new();
            for c in colors.into_iter().take(area.size.width as usize) {
                let _ = row.push(c);
                let _ = row.push(c);
            }
            let top = area.top_left * 2;
            let wide = Rectangle::new(top, Size::new(row.len() as u32, 1));
            self.0.fill_contiguous(&wide, row.iter().copied())?;
            let below = Rectangle::new(top + Point::new(0, 1), wide.size);
            return self.0.fill_contiguous(&below, row.iter().copied());
        }
        let points = area.points();
        self.draw_iter(points.zip(colors).map(|(p, c)| Pixel(p, c)))
    }
}
