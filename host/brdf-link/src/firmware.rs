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

/// Binary `bin` (`brdf-fw`, `embed-example`, and `core-cost`'s `cost` and `fitcost`) of the
/// default release build for QEMU, relative to the repository root:
/// `firmware/target/thumbv7em-none-eabihf/release/<bin>`.
pub fn qemu_elf(bin: &str) -> PathBuf {
    Core::M4F.elf(bin)
}

/// A core `firmware/core-cost` counts `brdf-core`'s instructions on, with the QEMU board that
/// stands in for it (the same pairs as `core-cost/build.rs`, which links each target for its
/// board, and `bench/firmware_cost.sh`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Core {
    /// Cortex-M0+ without FPU (`thumbv6m-none-eabi`) on QEMU's `microbit` (nRF51, a
    /// Cortex-M0: the same ARMv6-M instruction set), RAM enlarged to 64 KiB.
    M0Plus,
    /// Cortex-M4F (`thumbv7em-none-eabihf`) on the MPS2-AN386: the firmware's core.
    M4F,
    /// Cortex-M33 with FPU (`thumbv8m.main-none-eabihf`) on the MPS2-AN505, secure state.
    M33,
}

impl Core {
    /// Every core, smallest first.
    pub const ALL: [Core; 3] = [Core::M0Plus, Core::M4F, Core::M33];

    /// The Rust target triple.
    pub fn target(self) -> &'static str {
        match self {
            Core::M0Plus => "thumbv6m-none-eabi",
            Core::M4F => TARGET,
            Core::M33 => "thumbv8m.main-none-eabihf",
        }
    }

    /// The core's usual name.
    pub fn name(self) -> &'static str {
        match self {
            Core::M0Plus => "Cortex-M0+",
            Core::M4F => "Cortex-M4F",
            Core::M33 => "Cortex-M33",
        }
    }

    /// `qemu-system-arm`'s machine arguments for the core's stand-in board.
    pub fn qemu_machine(self) -> &'static [&'static str] {
        match self {
            Core::M0Plus => &["-machine", "microbit", "-global", "nrf51-soc.sram-size=65536"],
            Core::M4F => &["-machine", "mps2-an386", "-cpu", "cortex-m4"],
            Core::M33 => &["-machine", "mps2-an505", "-cpu", "cortex-m33"],
        }
    }

    /// Binary `bin` of the firmware workspace's release build for this core, relative to the
    /// repository root: `firmware/target/<target>/release/<bin>`.
    pub fn elf(self, bin: &str) -> PathBuf {
        Path::new(DIR)
            .join("target")
            .join(self.target())
            .join("release")
            .join(bin)
    }
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
        assert_eq!(
            Core::M33.elf("cost"),
            Path::new("firmware/target/thumbv8m.main-none-eabihf/release/cost")
        );
        // The firmware workspace of this checkout, and the memory map of each core's board.
        for core in Core::ALL {
            let board = core.qemu_machine()[1];
            let map = if board == "microbit" {
                "microbit".to_string()
            } else {
                board.trim_start_matches("mps2-").to_string()
            };
            assert!(
                in_repo(DIR).join(format!("core-cost/memory-{map}.x")).is_file(),
                "{core:?}"
            );
        }
        assert!(in_repo(DIR).join("Cargo.toml").is_file());
        assert!(in_repo(DIR).join("brdf-fw/src/main.rs").is_file());
    }
}
