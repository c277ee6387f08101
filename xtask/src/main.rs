//! Project tasks, run as `cargo xtask <task>` (the alias is in `.cargo/config.toml`).
//!
//! `cargo xtask test [ARGS...]` is the README's test command. On a fresh machine it first
//! installs what the tests need — the Rust targets and components listed in
//! `rust-toolchain.toml` (through rustup) and `qemu-system-arm` (through apt-get when it runs as
//! root or password-less sudo) — and stops at once with the exact command to run when it cannot.
//! Then it runs `cargo test --workspace --release ARGS...`.
//!
//! The firmware tests never pass without running: with no QEMU they fail, naming the install
//! command, unless the user opts out with `BRDF_SKIP_QEMU=1`, which prints a `SKIPPED:` line.

use std::path::{Path, PathBuf};
use std::process::{exit, Command, Stdio};

const USAGE: &str = "usage: cargo xtask test [ARGS passed to cargo test...]";

/// The QEMU board the firmware tests run on (Cortex-M4 with FPU).
const QEMU_BOARD: &str = "mps2-an386";

fn main() {
    let mut args = std::env::args().skip(1);
    match args.next().as_deref() {
        Some("test") => {
            let rest: Vec<String> = args.collect();
            let root = root();
            if let Err(e) = setup(&root) {
                eprintln!("error: {e}");
                exit(2);
            }
            exit(run_tests(&root, &rest));
        }
        Some("-h" | "--help") => println!("{USAGE}"),
        _ => {
            eprintln!("{USAGE}");
            exit(2);
        }
    }
}

/// The repository root (the parent of this crate).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the repository root")
        .to_path_buf()
}

fn setup(root: &Path) -> Result<(), String> {
    let toolchain = std::fs::read_to_string(root.join("rust-toolchain.toml"))
        .map_err(|e| format!("rust-toolchain.toml: {e}"))?;
    rust_pieces(&toolchain)?;
    qemu()
}

/// The quoted strings of `key = [ "a", "b" ]` in `rust-toolchain.toml` (one line).
fn toml_list(text: &str, key: &str) -> Vec<String> {
    text.lines()
        .map(str::trim)
        .filter_map(|l| l.strip_prefix(key)?.trim_start().strip_prefix('='))
        .flat_map(|v| v.split('"').skip(1).step_by(2).map(str::to_owned))
        .collect()
}

/// Targets and components of `rust-toolchain.toml`, added through rustup when missing.
fn rust_pieces(toolchain: &str) -> Result<(), String> {
    let targets = toml_list(toolchain, "targets");
    let components = toml_list(toolchain, "components");
    let Some(installed_targets) = output("rustup", &["target", "list", "--installed"]) else {
        // No rustup: the toolchain came from elsewhere; check the target's standard library.
        for t in &targets {
            let dir = output("rustc", &["--print", "target-libdir", "--target", t]);
            if !dir.is_some_and(|d| Path::new(d.trim()).exists()) {
                return Err(format!(
                    "the Rust standard library for {t} is missing and rustup is not installed; \
                     install Rust with rustup (https://rustup.rs), then run `rustup target add {t}`"
                ));
            }
        }
        return Ok(());
    };
    let installed: Vec<&str> = installed_targets.lines().map(str::trim).collect();
    for t in targets.iter().filter(|t| !installed.contains(&t.as_str())) {
        eprintln!("xtask: adding the Rust target {t}");
        run_or_explain("rustup", &["target", "add", t])?;
    }
    let installed = output("rustup", &["component", "list", "--installed"]).unwrap_or_default();
    for c in &components {
        let present = installed
            .lines()
            .any(|l| l.trim() == c || l.trim().starts_with(&format!("{c}-")));
        if !present {
            eprintln!("xtask: adding the Rust component {c}");
            run_or_explain("rustup", &["component", "add", c])?;
        }
    }
    Ok(())
}

/// `qemu-system-arm` with the firmware tests' board, installed through apt-get when possible.
fn qemu() -> Result<(), String> {
    if qemu_has_board() {
        return Ok(());
    }
    if std::env::var("BRDF_SKIP_QEMU").as_deref() == Ok("1") {
        println!(
            "SKIPPED: the firmware tests under QEMU (BRDF_SKIP_QEMU=1; qemu-system-arm with the \
             {QEMU_BOARD} board is not installed)"
        );
        return Ok(());
    }
    let install = "apt-get install -y qemu-system-arm";
    let sudo = if output("id", &["-u"]).is_some_and(|u| u.trim() == "0") {
        Some(false)
    } else if quiet_ok("sudo", &["-n", "true"]) {
        Some(true)
    } else {
        None
    };
    if let (Some(sudo), true) = (sudo, quiet_ok("apt-get", &["--version"])) {
        eprintln!("xtask: installing qemu-system-arm with apt-get (about a minute)");
        let prefix: &[&str] = if sudo { &["sudo", "-n"] } else { &[] };
        let apt = |args: &[&str]| {
            let mut all: Vec<&str> = prefix.to_vec();
            all.push("apt-get");
            all.extend_from_slice(args);
            Command::new(all[0])
                .args(&all[1..])
                .env("DEBIAN_FRONTEND", "noninteractive")
                .status()
                .is_ok_and(|s| s.success())
        };
        if apt(&["update", "-qq"]) && apt(&["install", "-y", "-qq", "qemu-system-arm"]) {
            if qemu_has_board() {
                return Ok(());
            }
            return Err(format!(
                "qemu-system-arm was installed but has no {QEMU_BOARD} board (`qemu-system-arm \
                 -machine help`); install a newer QEMU (Debian 12's 7.2 has it)"
            ));
        }
    }
    Err(format!(
        "the firmware tests need qemu-system-arm with the {QEMU_BOARD} board, which is not \
         installed and could not be installed here. Install it, then run the tests again:\n    \
         sudo {install}        (Debian, Ubuntu)\n    sudo dnf install qemu-system-arm  \
         (Fedora)\n    brew install qemu                 (macOS)\nor skip the firmware tests \
         explicitly: BRDF_SKIP_QEMU=1 cargo xtask test"
    ))
}

fn qemu_has_board() -> bool {
    output("qemu-system-arm", &["-machine", "help"])
        .is_some_and(|o| o.lines().any(|l| l.split_whitespace().next() == Some(QEMU_BOARD)))
}

fn run_tests(root: &Path, rest: &[String]) -> i32 {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["test", "--workspace", "--release", "--no-fail-fast"])
        .args(rest)
        .current_dir(root)
        .status();
    match status {
        Ok(s) => s.code().unwrap_or(1),
        Err(e) => {
            eprintln!("error: cannot run cargo test: {e}");
            1
        }
    }
}

/// Standard output of a command that ran and succeeded.
fn output(cmd: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(cmd).args(args).stderr(Stdio::null()).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

fn quiet_ok(cmd: &str, args: &[&str]) -> bool {
    Command::new(cmd)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn run_or_explain(cmd: &str, args: &[&str]) -> Result<(), String> {
    let line = format!("{cmd} {}", args.join(" "));
    match Command::new(cmd).args(args).status() {
        Ok(s) if s.success() => Ok(()),
        _ => Err(format!(
            "`{line}` failed; run it yourself, then run the tests again"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::toml_list;

    #[test]
    fn reads_the_toolchain_lists() {
        let text = "[toolchain]\nchannel = \"stable\"\ncomponents = [\"rustfmt\", \"clippy\"]\n\
                    targets = [ \"thumbv7em-none-eabihf\" ]\n";
        assert_eq!(toml_list(text, "components"), ["rustfmt", "clippy"]);
        assert_eq!(toml_list(text, "targets"), ["thumbv7em-none-eabihf"]);
        assert!(toml_list(text, "profile").is_empty());
    }
}
