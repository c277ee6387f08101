//! Where this repository's firmware builds put their ELF files: the one place that spells the
//! paths, for the defaults of `brdf check`, `brdf query` and `brdf flash`, `brdf bench` and
//! the tests that build and run the firmware.
//!
//! The firmware is its own Cargo workspace ([`DIR`]) built for `thumbv7em-none-eabihf`; the
//! default build runs under QEMU (`cd firmware && cargo build --release`), the STM32F407 build
//! goes to its own target directory (`--no-default-features --features hardware
//! --target-dir target/hardware`).

use std::path::{Path, PathBuf};

/// The firmware workspace, relative to the repository root.
pub const DIR: &str = "firmware";

/// The firmware's target triple (Cortex-M4F with hardware floating point).
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// Binary `bin` (`brdf-fw`, `cost`, `fitcost`, `embed-example`) of the default release build
/// for QEMU, relative to the repository root:
/// `firmware/target/thumbv7em-none-eabihf/release/<bin>`.
pub fn qemu_elf(bin: &str) -> PathBuf {
    Path::new(DIR)
        .join("target")
        .join(TARGET)
        .join("release")
        .join(bin)
}

/// The STM32F407 release build of `brdf-fw`, relative to the repository root:
/// `firmware/target/hardware/thumbv7em-none-eabihf/release/brdf-fw`.
pub fn hardware_elf() -> PathBuf {
    Path::new(DIR)
        .join("target/hardware")
        .join(TARGET)
        .join("release/brdf-fw")
}

/// `relative` (a path from the repository root, such as [`qemu_elf`]'s) in the checkout this
/// crate was built from.
pub fn in_repo(relative: impl AsRef<Path>) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(relative)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_the_builds_outputs() {
        assert_eq!(
            qemu_elf("brdf-fw"),
            Path::new("firmware/target/thumbv7em-none-eabihf/release/brdf-fw")
        );
        assert_eq!(
            hardware_elf(),
            Path::new("firmware/target/hardware/thumbv7em-none-eabihf/release/brdf-fw")
        );
        // The firmware workspace of this checkout.
        assert!(in_repo(DIR).join("Cargo.toml").is_file());
        assert!(in_repo(DIR).join("brdf-fw/src/main.rs").is_file());
    }
}
