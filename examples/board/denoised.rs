//! The denoised frame on a board, streamed: each pixel's samples are
//! rendered when the core's denoiser needs them (`micropt::denoise::
//! denoise_with`, a few rows ahead of the row it filters), and each
//! denoised row goes to the panel as soon as it is chosen. No frame of
//! samples and no framebuffer: the memory is the denoiser's rings (one
//! `Column` a pixel of a row, `micropt::denoise::workspace_bytes`), one
//! row of moments and one row of panel colours. The image is the host's
//! `micropt render SCENE --size WxH --spp N --seed S --uniform --denoise`,
//! bit for bit.
//!
//! On two cores (`mailbox.rs`): core 1 renders the odd pixels of each row
//! and hands them over; core 0 renders the even ones, denoises and draws.
//!
//! Shared by the board crates in `examples/boards/` (`#[path]`).

use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::{Point, Size};
use embedded_graphics::primitives::Rectangle;
use micropt::denoise::{self, Column, Moments};
use micropt::film::{FromEncoded, tone_map};
use micropt::{Renderer, Stats};

/// Pixel (x, y)'s `spp` samples summed into its moments (in sample order:
/// the host's sums).
pub fn moments(r: &Renderer<'_>, x: u32, y: u32, spp: u32, stats: &mut Stats) -> Moments {
    let pixel = r.pixel(x, y);
    let mut m = Moments::ZERO;
    for k in 0..spp {
        m.add(r.sample_parts_in(&pixel, x, y, k, stats), k < spp / 2);
    }
    m
}

/// Why a denoised frame stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The denoiser's workspace or the row buffers are narrower than the
    /// image.
    Workspace,
    /// The panel refused a row.
    Draw,
}

impl FrameError {
    /// What went wrong, for the log.
    pub fn what(self) -> &'static str {
        match self {
            FrameError::Workspace => "the denoiser's workspace is narrower than the image",
            FrameError::Draw => "drawing a row to the panel",
        }
    }
}

/// Renders and denoises `r`'s frame at `spp` samples a pixel into
/// `target`, row by row (tone-mapped at `exposure`, dithered by the
/// colour's `FromEncoded`). `pixel(x, y)` gives each pixel's moments when
/// the denoiser asks (row by row, left to right): [`moments`] on one core,
/// `mailbox::TwoCores::pixel` on two. `columns` and `line` hold at least a row's
/// pixels; `on_row(y)` is called as row `y` reaches the panel.
#[allow(clippy::too_many_arguments)]
pub fn frame<D>(
    r: &Renderer<'_>,
    spp: u32,
    exposure: f32,
    columns: &mut [Column],
    line: &mut [D::Color],
    pixel: impl FnMut(u32, u32) -> Moments,
    target: &mut D,
    mut on_row: impl FnMut(u32),
) -> Result<(), FrameError>
where
    D: DrawTarget,
    D::Color: FromEncoded,
{
    let w = r.width();
    if line.len() < w as usize {
        return Err(FrameError::Workspace);
    }
    let mut failed = false;
    denoise::denoise_with(
        r,
        pixel,
        spp,
        columns,
        |_, _, _| {},
        |y, x, c| {
            if let Some(px) = line.get_mut(x as usize) {
                *px = D::Color::from_encoded(tone_map(c, exposure), x, y);
            }
            if x + 1 == w {
                let row = Rectangle::new(Point::new(0, y as i32), Size::new(w, 1));
                let colours = line.iter().take(w as usize).copied();
                failed |= target.fill_contiguous(&row, colours).is_err();
                on_row(y);
            }
        },
    )
    .map_err(|_| FrameError::Workspace)?;
    if failed {
        return Err(FrameError::Draw);
    }
    Ok(())
}
