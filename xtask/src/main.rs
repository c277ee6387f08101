//! Project tasks, run as `cargo xtask <task>` (the alias is in `.cargo/config.toml`).
//!
//! `cargo xtask test [ARGS...]` is the README's test command. On a fresh machine it first
//! installs what the tests need — the Rust targets and components listed in
//! `rust-toolchain.toml` (through rustup) and `qemu-system-arm` (through apt-get when it runs as
//! root or password-less sudo) — and stops at once with the exact command to run when it cannot.
//! Then it builds the firmware once (the commands of `brdf_link::firmware::FIRMWARE_BUILDS`,
//! which the tests run again as no-ops), runs `cargo test --workspace --profile suite ARGS...`
//! (the `suite` profile: optimised, without LTO, incremental; see `Cargo.toml`), and then the
//! Python package's tests (`cargo xtask test-python` runs those alone): a virtual environment
//! in `<target>/py-venv` gets `host/brdf-py` and its test requirements (from its
//! `pyproject.toml`) through pip, built by maturin in the same profile and target folder (so it
//! reuses the compiled dependencies it shares with the workspace), and `python -m pytest
//! host/brdf-py/tests` runs against the `brdf` the Rust tests ran. `<target>` is the target
//! folder cargo reports (`cargo metadata`), so `CARGO_TARGET_DIR` is honoured everywhere. A
//! machine without `python3`, `venv` or `pip` stops with the command that installs them.
//!
//! The firmware tests never pass without running: with no QEMU they fail, naming the install
//! command, unless the user opts out with `BRDF_SKIP_QEMU=1`, which prints a `SKIPPED:` line.

use std::path::{Path, PathBuf};
use std::process::{exit, Command, Stdio};

const USAGE: &str = "usage: cargo xtask test [ARGS passed to cargo test...]\n       \
                     cargo xtask test-python   (the Python package's tests alone)";

/// The Python package: its own Cargo workspace, built by maturin through pip.
const PY_PACKAGE: &str = "host/brdf-py";
/// Where the Python package's tests run: a virtual environment in the target folder.
const PY_VENV: &str = "py-venv";

/// The cargo profile of the test build (root `Cargo.toml`, and the Python package's).
const PROFILE: &str = "suite";

// The firmware build commands, shared with `brdf_link::firmware` (which the tests call).
include!("../../host/brdf-link/src/firmware_builds.rs");

/// The QEMU boards the firmware tests run on: the firmware's (Cortex-M4 with FPU), then the
/// stand-ins for a Cortex-M33 and a Cortex-M0+ that `firmware/core-cost` counts on
/// (`brdf_link::firmware::Core`).
const QEMU_BOARDS: [&str; 3] = ["mps2-an386", "mps2-an505", "microbit"];

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
            if let Err(e) = build_firmware(&root) {
                eprintln!("error: {e}");
                exit(2);
            }
            let rust = run_tests(&root, &rest);
            let python = python_tests(&root);
            exit(if rust != 0 { rust } else { python });
        }
        Some("test-python") => exit(python_tests(&root())),
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
    qemu()?;
    python_present()
}

/// `python3` with `venv` and `pip`'s bootstrap, checked before the long Rust tests.
fn python_present() -> Result<(), String> {
    if quiet_ok("python3", &["-c", "import venv, ensurepip"]) {
        Ok(())
    } else {
        Err(format!("python3 with venv was not found; {PYTHON_INSTALL}"))
    }
}

/// The quoted strings of `key = [ "a", "b" ]` on one line of a TOML file (`rust-toolchain.toml`,
/// a `pyproject.toml`).
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
             boards {QEMU_BOARDS:?} is not installed)"
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
                "qemu-system-arm was installed but lacks one of the boards {QEMU_BOARDS:?} \
                 (`qemu-system-arm -machine help`); install a newer QEMU (Debian 12's 7.2 has \
                 them)"
            ));
        }
    }
    Err(format!(
        "the firmware tests need qemu-system-arm with the boards {QEMU_BOARDS:?}, which is not \
         installed and could not be installed here. Install it, then run the tests again:\n    \
         sudo {install}        (Debian, Ubuntu)\n    sudo dnf install qemu-system-arm  \
         (Fedora)\n    brew install qemu                 (macOS)\nor skip the firmware tests \
         explicitly: BRDF_SKIP_QEMU=1 cargo xtask test"
    ))
}

fn qemu_has_board() -> bool {
    output("qemu-system-arm", &["-machine", "help"]).is_some_and(|o| {
        QEMU_BOARDS
            .iter()
            .all(|b| o.lines().any(|l| l.split_whitespace().next() == Some(*b)))
    })
}

fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

/// The target folder cargo uses for this workspace (`CARGO_TARGET_DIR`, a configured
/// `build.target-dir`, or `target/`), as `cargo metadata` reports it.
fn target_dir(root: &Path) -> Result<PathBuf, String> {
    let out = Command::new(cargo())
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .current_dir(root)
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
    if !out.status.success() {
        return Err(format!("cargo metadata failed ({})", out.status));
    }
    json_string(&String::from_utf8_lossy(&out.stdout), "target_directory")
        .map(PathBuf::from)
        .ok_or_else(|| "cargo metadata reported no target_directory".into())
}

/// The value of the first `"key": "value"` of a JSON text (string values with `\\` and `\"`
/// escapes: a path).
fn json_string(json: &str, key: &str) -> Option<String> {
    let at = json.find(&format!("\"{key}\""))? + key.len() + 2;
    let rest = json[at..]
        .trim_start()
        .strip_prefix(':')?
        .trim_start()
        .strip_prefix('"')?;
    let mut value = String::new();
    let mut chars = rest.chars();
    loop {
        match chars.next()? {
            '"' => return Some(value),
            '\\' => value.push(chars.next()?),
            c => value.push(c),
        }
    }
}

/// Builds every firmware program once, before the tests (which run the same commands as
/// no-ops). Without the cross targets under `BRDF_SKIP_QEMU=1` it says so and goes on.
fn build_firmware(root: &Path) -> Result<(), String> {
    for (target, args) in FIRMWARE_BUILDS {
        eprintln!("xtask: building the firmware for {target}");
        if let Err(e) = run_in(&root.join("firmware"), &cargo(), args, &[]) {
            if std::env::var("BRDF_SKIP_QEMU").as_deref() == Ok("1") {
                println!("SKIPPED: the firmware build for {target} (BRDF_SKIP_QEMU=1): {e}");
                continue;
            }
            return Err(format!("the firmware did not build: {e}"));
        }
    }
    Ok(())
}

fn run_tests(root: &Path, rest: &[String]) -> i32 {
    let status = Command::new(cargo())
        .args(["test", "--workspace", "--profile", PROFILE, "--no-fail-fast"])
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

/// The Python package's tests: sets up [`PY_VENV`], installs the package with its test
/// requirements, builds `brdf` for the CLI comparisons and runs pytest. Returns the exit
/// code; a setup failure is printed with what to do.
fn python_tests(root: &Path) -> i32 {
    let run = target_dir(root).and_then(|target| {
        let python = python_setup(root, &target)?;
        pytest(root, &target, &python)
    });
    match run {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            1
        }
    }
}

/// The command that installs Python with `venv` and `pip` where they are missing.
const PYTHON_INSTALL: &str = "the Python package's tests need python3 (3.9 or later) with venv and pip. \
     Install them, then run the tests again:\n    sudo apt-get install -y python3 python3-venv python3-pip   \
     (Debian, Ubuntu)\n    sudo dnf install python3 python3-pip                        (Fedora)\n    \
     brew install python                                          (macOS)";

/// Creates [`PY_VENV`] when needed and installs the package there with its test extra;
/// returns the environment's interpreter.
fn python_setup(root: &Path, target: &Path) -> Result<PathBuf, String> {
    let venv = target.join(PY_VENV);
    let python = venv.join("bin").join("python");
    let has_pip = |py: &Path| quiet_ok(&py.to_string_lossy(), &["-m", "pip", "--version"]);
    if !has_pip(&python) {
        python_present()?;
        eprintln!("xtask: creating the Python environment {}", venv.display());
        // A half-made environment (no pip: Debian without python3-venv) is made anew.
        let _ = std::fs::remove_dir_all(&venv);
        let made = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .is_ok_and(|s| s.success());
        if !made || !has_pip(&python) {
            return Err(format!(
                "`python3 -m venv {}` gave no working pip; {PYTHON_INSTALL}",
                venv.display()
            ));
        }
    }
    let pyproject = std::fs::read_to_string(root.join(PY_PACKAGE).join("pyproject.toml"))
        .map_err(|e| format!("{PY_PACKAGE}/pyproject.toml: {e}"))?;
    // The build backend (maturin) as the package requires it, installed once: the package is
    // then built without pip's isolated build environment, so later runs need no index.
    let backend = toml_list(&pyproject, "requires");
    if backend.is_empty() {
        return Err(format!("{PY_PACKAGE}/pyproject.toml: no build-system `requires`"));
    }
    let py = python.to_string_lossy().into_owned();
    let mut args = vec!["-m", "pip", "install", "--quiet", "--disable-pip-version-check"];
    args.extend(backend.iter().map(String::as_str));
    run_in(root, &py, &args, &[])?;
    eprintln!(
        "xtask: building and installing {PY_PACKAGE} into {} (profile {PROFILE}, target {})",
        venv.display(),
        target.display()
    );
    let spec = format!("./{PY_PACKAGE}[test]");
    // As an activated environment: maturin's build hook runs the `maturin` of PATH.
    let mut path = std::ffi::OsString::from(venv.join("bin"));
    if let Some(p) = std::env::var_os("PATH") {
        path.push(":");
        path.push(p);
    }
    run_in(
        root,
        &py,
        &[
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "--no-build-isolation",
            &spec,
        ],
        &[
            ("CARGO_TARGET_DIR", target.as_os_str()),
            (
                "MATURIN_PEP517_ARGS",
                std::ffi::OsStr::new(&format!("--profile {PROFILE}")),
            ),
            ("PATH", &path),
            ("VIRTUAL_ENV", venv.as_os_str()),
        ],
    )?;
    Ok(python)
}

/// `brdf` for the CLI comparisons, then pytest over the package's tests (no tests collected
/// is a failure).
fn pytest(root: &Path, target: &Path, python: &Path) -> Result<(), String> {
    // The `brdf` the Rust tests ran (cargo puts a test's binaries in the profile's folder):
    // the workspace's test build, a no-op after the Rust tests, brings it up to date when they
    // were narrowed to other packages (`cargo build -p brdf-cli` would resolve features anew
    // and rebuild much of the workspace).
    run_in(
        root,
        &cargo(),
        &["test", "--workspace", "--profile", PROFILE, "--no-run", "--quiet"],
        &[],
    )?;
    let cli = target.join(PROFILE).join("brdf");
    let tests = format!("{PY_PACKAGE}/tests");
    eprintln!("xtask: python -m pytest {tests}");
    let status = Command::new(python)
        .args(["-m", "pytest", &tests])
        .env("BRDF_CLI", &cli)
        .current_dir(root)
        .status()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    match status.code() {
        Some(0) => Ok(()),
        Some(5) => Err(format!("pytest collected no tests in {tests}")),
        _ => Err(format!("the Python package's tests failed (pytest {status})")),
    }
}

/// Runs `cmd args` in `dir` with extra environment variables; an error names the command.
fn run_in(dir: &Path, cmd: &str, args: &[&str], env: &[(&str, &std::ffi::OsStr)]) -> Result<(), String> {
    let line = format!("{cmd} {}", args.join(" "));
    let status = Command::new(cmd)
        .args(args)
        .envs(env.iter().copied())
        .current_dir(dir)
        .status()
        .map_err(|e| format!("cannot run `{line}`: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{line}` failed ({status})"))
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
    use super::{json_string, toml_list};

    #[test]
    fn reads_a_string_of_cargo_metadata() {
        let json = r#"{"packages":[],"target_directory":"/a/b \"c\"\\d","version":1}"#;
        assert_eq!(
            json_string(json, "target_directory").as_deref(),
            Some(r#"/a/b "c"\d"#)
        );
        assert_eq!(json_string(json, "workspace_root"), None);
        assert_eq!(
            json_string(r#"{"target_directory":"/unterminated"#, "target_directory"),
            None
        );
    }

    #[test]
    fn reads_the_toolchain_lists() {
        let text = "[toolchain]\nchannel = \"stable\"\ncomponents = [\"rustfmt\", \"clippy\"]\n\
                    targets = [ \"thumbv7em-none-eabihf\" ]\n";
        assert_eq!(toml_list(text, "components"), ["rustfmt", "clippy"]);
        assert_eq!(toml_list(text, "targets"), ["thumbv7em-none-eabihf"]);
        assert!(toml_list(text, "profile").is_empty());
        let pyproject = "[build-system]\nrequires = [\"maturin>=1.9,<2\"]\nbuild-backend = \"maturin\"\n";
        assert_eq!(toml_list(pyproject, "requires"), ["maturin>=1.9,<2"]);
    }
}
