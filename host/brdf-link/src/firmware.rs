//! Where this repository's firmware builds put their ELF files, and the builds themselves: the
//! one place that spells them, for the defaults of `brdf check`, `brdf query` and `brdf flash`,
//! `brdf bench` and the tests that build and run the firmware.
//!
//! The firmware is its own Cargo workspace ([`DIR`]) built for `thumbv7em-none-eabihf`; the
//! default build runs under QEMU (`cd firmware && cargo build --release`), the STM32F407 build
//! goes to its own target directory (`--no-default-features --features hardware
//! --target-dir target/hardware`). [`build`] runs a build and reads where cargo put each
//! program, so tests work with any `CARGO_TARGET_DIR`.

use std::path::{Path, PathBuf};

/// The firmware workspace, relative to the repository root.
pub const DIR: &str = "firmware";

/// The firmware's target triple (Cortex-M4F with hardware floating point).
pub const TARGET: &str = "thumbv7em-none-eabihf";

include!("firmware_builds.rs");

/// The default build of binary `bin` (`brdf-fw`, `embed-example`, and `core-cost`'s `cost` and
/// `fitcost`) for QEMU's Cortex-M4F board: [`Core::elf`] of [`Core::M4F`].
pub fn qemu_elf(bin: &str) -> PathBuf {
    Core::M4F.elf(bin)
}

/// Where `cargo build` in the firmware workspace puts its output when run as this process
/// would run it: `$CARGO_TARGET_DIR` when set (relative to the current directory, as cargo
/// reads it), else `firmware/target` of this checkout. A target directory set in a cargo
/// configuration file instead is not seen: [`build`] asks cargo itself.
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => in_repo(DIR).join("target"),
    }
}

/// The programs one firmware build made, by binary name, as cargo reported them.
#[derive(Clone, Debug, Default)]
pub struct Programs(std::collections::BTreeMap<String, PathBuf>);

impl Programs {
    /// The ELF of binary `bin`, if the build made it.
    pub fn get(&self, bin: &str) -> Option<&Path> {
        self.0.get(bin).map(PathBuf::as_path)
    }
}

/// Builds every firmware program for `core` with the command of [`FIRMWARE_BUILDS`] (a no-op
/// when nothing changed) and returns where cargo put each, read from its JSON messages, so
/// the result holds wherever the target directory is. `Err` says why the build failed (the
/// cross target missing, a compile error: cargo's diagnostics go to standard error).
pub fn build(core: Core) -> Result<Programs, String> {
    let target = core.target();
    let (_, args) = FIRMWARE_BUILDS
        .iter()
        .find(|(t, _)| *t == target)
        .ok_or_else(|| format!("no firmware build for {target}"))?;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = std::process::Command::new(&cargo)
        .args(*args)
        .arg("--message-format=json-render-diagnostics")
        .current_dir(in_repo(DIR))
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo ({}): {e}", cargo.to_string_lossy()))?;
    if !out.status.success() {
        return Err(format!(
            "`cargo {}` in {DIR}/ failed ({}); is the target installed (`rustup target add {target}`)?",
            args.join(" "),
            out.status
        ));
    }
    let mut programs = Programs::default();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if msg["reason"] != "compiler-artifact" {
            continue;
        }
        if let (Some(exe), Some(name)) = (msg["executable"].as_str(), msg["target"]["name"].as_str()) {
            programs.0.insert(name.to_owned(), PathBuf::from(exe));
        }
    }
    if programs.0.is_empty() {
        return Err(format!(
            "`cargo {}` in {DIR}/ reported no program",
            args.join(" ")
        ));
    }
    Ok(programs)
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

    /// Binary `bin` of the firmware workspace's release build for this core, where a plain
    /// `cargo build` would put it: `<target_dir()>/<target>/release/<bin>` ([`target_dir`]).
    /// Tests and benchmarks use [`build`], which asks cargo.
    pub fn elf(self, bin: &str) -> PathBuf {
        target_dir().join(self.target()).join("release").join(bin)
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
        assert!(qemu_elf("brdf-fw").ends_with("thumbv7em-none-eabihf/release/brdf-fw"));
        assert_eq!(
            hardware_elf(),
            Path::new("firmware/target/hardware/thumbv7em-none-eabihf/release/brdf-fw")
        );
        assert!(Core::M33
            .elf("cost")
            .starts_with(target_dir().join("thumbv8m.main-none-eabihf")));
        // One build command per core, for its target.
        for core in Core::ALL {
            let (_, args) = FIRMWARE_BUILDS.iter().find(|(t, _)| *t == core.target()).unwrap();
            assert!(
                args.windows(2).any(|w| w == ["--target", core.target()]),
                "{core:?}"
            );
        }
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
