//! Puts the memory map of the QEMU board that stands in for the target's core on the linker
//! search path as `memory.x`, and links the binaries with cortex-m-rt's `link.x`:
//! - `thumbv6m-none-eabi` (Cortex-M0+, no FPU): `microbit` (nRF51, a Cortex-M0: the same
//!   ARMv6-M instruction set), its RAM enlarged on the QEMU command line;
//! - `thumbv7em-none-eabihf` (Cortex-M4F): `mps2-an386`, the firmware's board;
//! - `thumbv8m.main-none-eabihf` (Cortex-M33): `mps2-an505`, running in the secure state.
use std::path::PathBuf;

fn main() {
    let target = std::env::var("TARGET").expect("TARGET");
    let board = match target.as_str() {
        "thumbv6m-none-eabi" => "microbit",
        "thumbv7em-none-eabihf" => "an386",
        "thumbv8m.main-none-eabihf" => "an505",
        other => panic!(
            "core-cost has no QEMU board for {other}: build it for thumbv6m-none-eabi, \
             thumbv7em-none-eabihf or thumbv8m.main-none-eabihf"
        ),
    };
    // `cfg(board = "...")` selects the board's SysTick clock in `ticks`.
    println!("cargo:rustc-check-cfg=cfg(board, values(\"microbit\", \"an386\", \"an505\"))");
    println!("cargo:rustc-cfg=board=\"{board}\"");
    let map = format!("memory-{board}.x");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    std::fs::copy(&map, out.join("memory.x")).expect("copy memory map");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    for f in [
        "memory-microbit.x",
        "memory-an386.x",
        "memory-an505.x",
        "build.rs",
    ] {
        println!("cargo:rerun-if-changed={f}");
    }
}
