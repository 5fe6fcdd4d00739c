//! A panic's message on the panel: white on red from the top, the 6 × 10
//! mono font, cut into lines at the panel's width and at its newlines.
//!
//! Shared by the board crates in `examples/boards/` (`#[path]`).

use core::cell::RefCell;
use critical_section::Mutex;
use embedded_graphics::Drawable;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::{OriginDimensions, Point, Size};
use embedded_graphics::mono_font::{MonoTextStyle, ascii::FONT_6X10};
use embedded_graphics::pixelcolor::{Rgb565, RgbColor};
use embedded_graphics::primitives::Rectangle;
use embedded_graphics::text::{Baseline, Text};

/// Writes `text` on the panel in `panel` (a panic handler's view of the
/// panel the demo draws to), unless the panel is not set up or is in the
/// middle of a drawing call (the panic struck there).
pub fn show<D>(panel: &Mutex<RefCell<Option<D>>>, text: &str)
where
    D: DrawTarget<Color = Rgb565> + OriginDimensions,
{
    critical_section::with(|cs| {
        if let Ok(mut panel) = panel.borrow(cs).try_borrow_mut()
            && let Some(panel) = panel.as_mut()
        {
            let _ = write_text(panel, text);
        }
    });
}

/// Writes `text` on `panel` (as many lines as fit).
pub fn write_text<D>(panel: &mut D, text: &str) -> Result<(), D::Error>
where
    D: DrawTarget<Color = Rgb565> + OriginDimensions,
{
    let size = panel.size();
    let cols = (size.width / 6).max(1) as usize;
    let style = MonoTextStyle::new(&FONT_6X10, Rgb565::WHITE);
    let bottom = size.height as i32;
    let mut y = 0;
    for part in text.split('\n') {
        let mut rest = part;
        loop {
            if y + 10 > bottom {
                return Ok(());
            }
            let cut = rest.char_indices().nth(cols).map_or(rest.len(), |(i, _)| i);
            let (now, later) = rest.split_at(cut);
            let band = Rectangle::new(Point::new(0, y), Size::new(size.width, 10));
            panel.fill_solid(&band, Rgb565::RED)?;
            Text::with_baseline(now, Point::new(0, y), style, Baseline::Top).draw(panel)?;
            y += 10;
            rest = later;
            if rest.is_empty() {
                break;
            }
        }
    }
    Ok(())
}
