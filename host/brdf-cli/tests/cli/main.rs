//! The `brdf` command line end to end: every subcommand run as a user would.
//!
//! One test binary for the crate (one link instead of one per file); each module is one
//! concern, run alone with `cargo test -p PACKAGE --test BINARY MODULE::`.

mod adversarial;
mod bench;
mod check;
mod eval;
mod fit;
mod fitted;
mod report;
mod scene;

use std::process::{Command, Output};

/// The `brdf` binary cargo built for these tests.
pub fn brdf_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_brdf"))
}

/// `args` with `--elf FIRMWARE` (the build the tests made, wherever cargo put it) after a
/// `--qemu` that names no ELF. Without QEMU under `BRDF_SKIP_QEMU=1`, `args` as given.
pub fn with_firmware(args: &[&str]) -> Vec<String> {
    let mut out: Vec<String> = args.iter().map(|a| a.to_string()).collect();
    if args.contains(&"--qemu") && !args.contains(&"--elf") {
        if let Some(elf) = brdf_tests::qemu::firmware() {
            out.push("--elf".into());
            out.push(elf.display().to_string());
        }
    }
    out
}

/// Runs `brdf args` (with [`with_firmware`]) to completion.
pub fn brdf(args: &[&str]) -> Output {
    brdf_command().args(with_firmware(args)).output().unwrap()
}
