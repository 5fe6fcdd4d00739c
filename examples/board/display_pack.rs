//! The Pimoroni Pico Display Pack on either Pico: its pins, the ST7789's
//! SPI set-up, the buttons A/B/X/Y and the RGB LED, written once for the
//! RP2040 and the RP2350 (their HALs, `crate::hal`, spell GPIO and SPI the
//! same way). Which pack: the cargo feature `pack-114` (Display Pack,
//! 1.14", 240×135) or `pack-20` (Display Pack 2.0, 2.0", 320×240), the
//! same pins on both (Pimoroni's pinout):
//!
//! | pack      | GPIO |
//! | --------- | ---- |
//! | SCK       | GP18 (SPI0 SCK) |
//! | MOSI      | GP19 (SPI0 TX)  |
//! | CS        | GP17 |
//! | DC        | GP16 |
//! | backlight | GP20 (high after the panel is cleared) |
//! | RGB LED   | GP6 red, GP7 green, GP8 blue (active low) |
//! | A, B, X, Y | GP12, GP13, GP14, GP15 (to ground when pressed) |
//! | reset     | not wired (the panel resets at power-on) |
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

use crate::hal;
use crate::pico::{Led, Step};
use core::cell::RefCell;
use critical_section::Mutex;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::pixelcolor::{Rgb565, RgbColor};
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use hal::fugit::{HertzU32, RateExtU32};
use hal::gpio::bank0::{Gpio16, Gpio17, Gpio18, Gpio19, Gpio20};
use hal::gpio::{
    DynPinId, FunctionSioInput, FunctionSioOutput, FunctionSpi, Pin, PinState, PullDown, PullUp,
};
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::{ColorInversion, Orientation, Rotation};
use mipidsi::{Builder, NoResetPin};

#[cfg(all(feature = "pack-114", feature = "pack-20"))]
compile_error!("choose one Display Pack: feature pack-114 or pack-20, not both");
#[cfg(not(any(feature = "pack-114", feature = "pack-20")))]
compile_error!(
    "choose a Display Pack: feature pack-114 (1.14\", 240x135) or pack-20 (2.0\", 320x240)"
);

/// A pack's panel: its size in landscape, where that window sits in the
/// ST7789's 240×320 memory (before the quarter turn), its name.
pub struct Geometry {
    /// Width and height, landscape.
    pub size: (u32, u32),
    /// `mipidsi`'s display offset of the window.
    pub offset: (u16, u16),
    /// What the boot log calls it.
    pub name: &'static str,
}

/// The Display Pack 2.0: the whole 240×320 panel, turned a quarter.
#[cfg(feature = "pack-20")]
pub const PACK: Geometry = Geometry {
    size: (320, 240),
    offset: (0, 0),
    name: "Pico Display Pack 2.0 (320x240)",
};
/// The Display Pack (1.14"): a 135×240 window of the controller's 240×320
/// memory, turned a quarter.
#[cfg(not(feature = "pack-20"))]
pub const PACK: Geometry = Geometry {
    size: (240, 135),
    offset: (52, 40),
    name: "Pico Display Pack (240x135)",
};

type Spi0 = hal::spi::Spi<
    hal::spi::Enabled,
    hal::pac::SPI0,
    (
        Pin<Gpio19, FunctionSpi, PullDown>,
        Pin<Gpio18, FunctionSpi, PullDown>,
    ),
    8,
>;
type Cs = Pin<Gpio17, FunctionSioOutput, PullDown>;
type Dc = Pin<Gpio16, FunctionSioOutput, PullDown>;
/// The pack's panel through `mipidsi`.
pub type Panel = mipidsi::Display<
    SpiInterface<'static, ExclusiveDevice<Spi0, Cs, NoDelay>, Dc>,
    ST7789,
    NoResetPin,
>;
/// An output pin of the LED.
pub type LedPin = Pin<DynPinId, FunctionSioOutput, PullDown>;

/// The panel, where the demo draws ([`crate::locked_panel::LockedPanel`])
/// and where a panic writes its message ([`crate::pico`]'s handler).
pub static PANEL: Mutex<RefCell<Option<Panel>>> = Mutex::new(RefCell::new(None));

/// The pack's buttons A, B, X, Y (the raw frame reads none).
#[cfg_attr(feature = "raw", allow(dead_code))]
pub struct Buttons([Pin<DynPinId, FunctionSioInput, PullUp>; 4]);

#[cfg_attr(feature = "raw", allow(dead_code))]
impl Buttons {
    /// Which buttons are down (A, B, X, Y): each pulls its pin to ground.
    pub fn pressed(&mut self) -> [bool; 4] {
        let mut down = [false; 4];
        for (d, pin) in down.iter_mut().zip(self.0.iter_mut()) {
            *d = pin.is_low().unwrap_or(false);
        }
        down
    }
}

/// The pins the panel needs, set aside until the clocks run.
pub struct PanelPins {
    mosi: Pin<Gpio19, FunctionSpi, PullDown>,
    sck: Pin<Gpio18, FunctionSpi, PullDown>,
    cs: Cs,
    dc: Dc,
    backlight: Pin<Gpio20, FunctionSioOutput, PullDown>,
}

/// The pack's pins out of the chip's: the LED (off) and the backlight
/// (off) at once, so that a failed clock set-up can already blink; the
/// buttons; the panel's pins.
pub fn split(pins: hal::gpio::Pins) -> (Led<LedPin>, Buttons, PanelPins) {
    let led = Led([
        pins.gpio6
            .into_push_pull_output_in_state(PinState::High)
            .into_dyn_pin(),
        pins.gpio7
            .into_push_pull_output_in_state(PinState::High)
            .into_dyn_pin(),
        pins.gpio8
            .into_push_pull_output_in_state(PinState::High)
            .into_dyn_pin(),
    ]);
    let backlight = pins.gpio20.into_push_pull_output_in_state(PinState::Low);
    let buttons = Buttons([
        pins.gpio12.into_pull_up_input().into_dyn_pin(),
        pins.gpio13.into_pull_up_input().into_dyn_pin(),
        pins.gpio14.into_pull_up_input().into_dyn_pin(),
        pins.gpio15.into_pull_up_input().into_dyn_pin(),
    ]);
    let panel = PanelPins {
        mosi: pins.gpio19.into_function::<FunctionSpi>(),
        sck: pins.gpio18.into_function::<FunctionSpi>(),
        cs: pins.gpio17.into_push_pull_output(),
        dc: pins.gpio16.into_push_pull_output(),
        backlight,
    };
    (led, buttons, panel)
}

impl PanelPins {
    /// The panel on SPI0 at the fastest rate the peripheral clock
    /// (`peripheral_hz`) divides to at or below the ST7789's 62.5 MHz
    /// write clock (62.5 MHz from 125 MHz; 37.5 MHz from 150 MHz),
    /// initialised, cleared to black, then the backlight on. The step
    /// that failed, if one did.
    pub fn panel(
        self,
        spi0: hal::pac::SPI0,
        resets: &mut hal::pac::RESETS,
        peripheral_hz: HertzU32,
        delay: &mut impl DelayNs,
    ) -> Result<Panel, Step> {
        let PanelPins {
            mosi,
            sck,
            cs,
            dc,
            mut backlight,
        } = self;
        let spi: Spi0 = hal::spi::Spi::<_, _, _, 8>::new(spi0, (mosi, sck)).init(
            resets,
            peripheral_hz,
            62_500_000u32.Hz(),
            embedded_hal::spi::MODE_0,
        );
        let Ok(device) = ExclusiveDevice::new_no_delay(spi, cs);
        let buffer = cortex_m::singleton!(: [u8; 512] = [0; 512]).ok_or(Step::Memory)?;
        let di = SpiInterface::new(device, dc, buffer);
        let (w, h) = PACK.size;
        let mut panel: Panel = Builder::new(ST7789, di)
            .display_size(h as u16, w as u16)
            .display_offset(PACK.offset.0, PACK.offset.1)
            .orientation(Orientation::new().rotate(Rotation::Deg90))
            .invert_colors(ColorInversion::Inverted)
            .init(delay)
            .map_err(|_| Step::Panel)?;
        panel.clear(Rgb565::BLACK).map_err(|_| Step::Clear)?;
        let _ = backlight.set_high();
        Ok(panel)
    }
}
