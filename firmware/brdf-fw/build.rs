//! Puts the board's memory map on the linker search path as `memory.x` and links this
//! crate's binaries with cortex-m-rt's `link.x` and defmt's `defmt.x` (only these binaries:
//! the size probes link without them).
use std::path::PathBuf;

fn main() {
    let hardware = std::env::var_os("CARGO_FEATURE_HARDWARE").is_some();
    let qemu = std::env::var_os("CARGO_FEATURE_QEMU").is_some();
    if hardware == qemu {
        panic!("enable exactly one of the features `qemu` (default) and `hardware`");
    }
    let map = if hardware { "memory-stm32f4.x" } else { "memory.x" };
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    std::fs::copy(map, out.join("memory.x")).expect("copy memory map");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=memory-stm32f4.x");
    println!("cargo:rerun-if-changed=build.rs");
}
