//! One panel drawn to by both cores of a chip: the panel lives in a
//! `critical_section::Mutex`, and each core draws through its own
//! [`LockedPanel`], which holds the lock for one drawing call (one tile's
//! window write). On the RP2040 and RP2350 the HALs implement the critical
//! section with a SIO hardware spinlock (and interrupts masked), so it
//! excludes the other core.
//!
//! Shared by the board crates in `examples/boards/` (`#[path]`): the
//! Picos' raw frame (both cores), the demo and the panic handler.

use core::cell::RefCell;
use critical_section::Mutex;
use embedded_graphics::Pixel;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::{OriginDimensions, Size};
use embedded_graphics::primitives::Rectangle;

/// A view, for one core, of the panel in `panel` (empty until the panel is
/// set up: drawing then does nothing).
pub struct LockedPanel<D: 'static> {
    /// The shared panel.
    pub panel: &'static Mutex<RefCell<Option<D>>>,
    /// Its size.
    pub size: Size,
}

impl<D> OriginDimensions for LockedPanel<D> {
    fn size(&self) -> Size {
        self.size
    }
}

impl<D: DrawTarget> DrawTarget for LockedPanel<D> {
    type Color = D::Color;
    type Error = D::Error;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        critical_section::with(|cs| match self.panel.borrow_ref_mut(cs).as_mut() {
            Some(p) => p.draw_iter(pixels),
            None => Ok(()),
        })
    }

    fn fill_contiguous<I>(&mut self, area: &Rectangle, colors: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Self::Color>,
    {
        critical_section::with(|cs| match self.panel.borrow_ref_mut(cs).as_mut() {
            Some(p) => p.fill_contiguous(area, colors),
            None => Ok(()),
        })
    }
}
