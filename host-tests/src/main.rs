//! `micropt`: render scene files on the host with the same core the boards run.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

#[cfg(not(target_os = "none"))]
mod cli;

#[cfg(not(target_os = "none"))]
fn main() -> std::process::ExitCode {
    cli::main()
}
