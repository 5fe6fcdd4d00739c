//! A board's panel seen through a [`Progress`] counter: a `DrawTarget` that
//! forwards every drawing call to the panel and, from the number of tiles
//! drawn, tells the board when the preview covers the panel and
//! when each tenth of the refinement is on it, so a board can print (or
//! blink) how far a frame of several minutes has come.
//!
//! The executors draw each tile once per pass with one `fill_contiguous`
//! (`micropt::film::draw_tile_iter`): the first `tiles` calls are the
//! preview, the next `tiles` the refined tiles (a tile whose refinement
//! share is 0 is not drawn again; with a sample budget of at least 2
//! samples per pixel every tile has a share).
//!
//! Shared by the board crates in `examples/boards/` (`#[path]`).

use embedded_graphics::Pixel;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::Dimensions;
use embedded_graphics::primitives::Rectangle;

/// How far a frame has come.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Milestone {
    /// Every tile's preview is on the panel.
    Preview,
    /// This many percent (10, 20, ..., 100) of the tiles are refined.
    Refined(u32),
}

/// A panel whose drawn tiles are counted; `report` is called at each
/// [`Milestone`].
pub struct Progress<D> {
    /// The panel drawn to.
    pub panel: D,
    tiles: u32,
    drawn: u32,
    report: fn(Milestone),
}

impl<D> Progress<D> {
    /// Counts the tiles of an image of `tiles` tiles drawn to `panel`.
    pub const fn new(panel: D, tiles: u32, report: fn(Milestone)) -> Self {
        Self {
            panel,
            tiles,
            drawn: 0,
            report,
        }
    }

    /// Counts one drawn tile and reports the milestone it completes.
    fn count(&mut self) {
        self.drawn = self.drawn.saturating_add(1);
        let n = self.tiles.max(1);
        if self.drawn == n {
            (self.report)(Milestone::Preview);
        } else if self.drawn > n {
            let refined = self.drawn - n;
            // the first tile of each tenth: refined * 10 crosses a multiple of n
            if refined <= n && (refined * 10) / n != ((refined - 1) * 10) / n {
                (self.report)(Milestone::Refined((refined * 10) / n * 10));
            }
        }
    }
}

impl<D: Dimensions> Dimensions for Progress<D> {
    fn bounding_box(&self) -> Rectangle {
        self.panel.bounding_box()
    }
}

impl<D: DrawTarget> DrawTarget for Progress<D> {
    type Color = D::Color;
    type Error = D::Error;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        self.panel.draw_iter(pixels)
    }

    fn fill_contiguous<I>(&mut self, area: &Rectangle, colors: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Self::Color>,
    {
        let r = self.panel.fill_contiguous(area, colors);
        self.count();
        r
    }

    fn fill_solid(&mut self, area: &Rectangle, color: Self::Color) -> Result<(), Self::Error> {
        self.panel.fill_solid(area, color)
    }

    fn clear(&mut self, color: Self::Color) -> Result<(), Self::Error> {
        self.panel.clear(color)
    }
}
