//! The Picos' log over USB: a CDC-ACM serial port (usb-device and
//! usbd-serial, as rp-hal's examples set it up), so that a user with only a
//! USB cable sees what defmt sends to a debug probe: the boot lines, each
//! pass's status line, the buttons, a panic's message. The device is
//! polled from the USB interrupt (it must answer the host within
//! milliseconds, and a pass's pixel can take seconds); lines are written
//! into the port's buffer and dropped, not waited for, when no host reads
//! them.
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

use crate::hal;
use core::cell::RefCell;
use critical_section::Mutex;
use hal::pac::interrupt;
use static_cell::StaticCell;
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbVidPid};
use usbd_serial::SerialPort;

type Bus = hal::usb::UsbBus;

/// The device and its one serial port.
struct Usb {
    device: UsbDevice<'static, Bus>,
    serial: SerialPort<'static, Bus>,
}

impl Usb {
    /// Answers the host; what it sends is read and dropped.
    fn poll(&mut self) {
        if self.device.poll(&mut [&mut self.serial]) {
            let mut sink = [0u8; 64];
            let _ = self.serial.read(&mut sink);
        }
    }

    /// Writes as much of `bytes` as the port's buffer takes; how much.
    fn write(&mut self, bytes: &[u8]) -> usize {
        self.serial.write(bytes).unwrap_or(0)
    }
}

/// The bus allocator the device and port borrow for ever.
static BUS: StaticCell<UsbBusAllocator<Bus>> = StaticCell::new();
/// The device, polled from the USB interrupt and written by [`print`].
static USB: Mutex<RefCell<Option<Usb>>> = Mutex::new(RefCell::new(None));

/// Starts the serial port on `bus` (the chip's USB controller, clocked at
/// 48 MHz by the USB PLL) and unmasks its interrupt. Twice: ignored.
pub fn start(bus: Bus) {
    let Some(alloc) = BUS.try_init(UsbBusAllocator::new(bus)) else {
        return;
    };
    let serial = SerialPort::new(alloc);
    // the pid.codes test VID/PID rp-hal's serial examples use
    let Ok(builder) = UsbDeviceBuilder::new(alloc, UsbVidPid(0x16c0, 0x27dd)).strings(&[
        StringDescriptors::default()
            .manufacturer("micropt")
            .product("micropt demo log")
            .serial_number("0"),
    ]) else {
        return;
    };
    let device = builder.device_class(usbd_serial::USB_CLASS_CDC).build();
    critical_section::with(|cs| USB.borrow_ref_mut(cs).replace(Usb { device, serial }));
    // SAFETY: the handler below only takes the mutex, like every other
    // user of the device, so unmasking it cannot break a critical section
    unsafe { cortex_m::peripheral::NVIC::unmask(hal::pac::Interrupt::USBCTRL_IRQ) };
}

/// Writes `line` and a line end to the port, as much as its buffer takes
/// (the rest is dropped).
pub fn print(line: &str) {
    critical_section::with(|cs| {
        if let Some(usb) = USB.borrow_ref_mut(cs).as_mut() {
            let n = usb.write(line.as_bytes());
            if n == line.len() {
                usb.write(b"\r\n");
            }
        }
    });
}

/// For a panic, with interrupts off: writes `text` chunk by chunk while
/// polling the device itself, for about `ms` milliseconds at `hz`.
pub fn print_polling(text: &str, ms: u32, hz: u32) {
    let mut rest = text.as_bytes();
    for _ in 0..ms {
        critical_section::with(|cs| {
            if let Ok(mut usb) = USB.borrow(cs).try_borrow_mut()
                && let Some(usb) = usb.as_mut()
            {
                usb.poll();
                if !rest.is_empty() {
                    let n = usb.write(rest);
                    rest = rest.get(n..).unwrap_or(&[]);
                    if rest.is_empty() {
                        usb.write(b"\r\n");
                    }
                }
            }
        });
        cortex_m::asm::delay(hz / 1000);
    }
}

/// The USB controller's interrupt: the device answers the host.
#[interrupt]
fn USBCTRL_IRQ() {
    critical_section::with(|cs| {
        if let Some(usb) = USB.borrow_ref_mut(cs).as_mut() {
            usb.poll();
        }
    });
}
