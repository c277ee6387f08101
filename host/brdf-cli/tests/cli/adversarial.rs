//! Attacks on the command line and the link to the device (issue 14). Each test failed
//! before the fix it names: a QEMU that exits or never answers, a local process that tries
//! to pose as the device, arguments that are not durations, counts or sizes, `query` against
//! `eval`, parameter ranges across pack, check and fit, streaming, and error messages.
//!
//! The tests that run the firmware need `qemu-system-arm` and the cross target (or
//! `BRDF_SKIP_QEMU=1`).

use std::collections::HashSet;
use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::LazyLock;
use std::time::{Duration, Instant};

use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_wire::frame::{encode_response, Response, MAX_FRAME};

/// Khaki (Table 1) as a `--params` argument.
static KHAKI: LazyLock<String> = LazyLock::new(|| brdf_tests::table1_params_arg(0));

use crate::brdf_command as brdf;

fn run(args: &[&str]) -> Output {
    crate::brdf(args)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Waits for `child` at most `limit`; a child still running then is killed and the test
/// fails: the command hung.
fn finish_within(mut child: Child, limit: Duration, what: &str) -> Output {
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let o = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = out.read_to_end(&mut v);
        v
    });
    let e = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = err.read_to_end(&mut v);
        v
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}: it hangs");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output {
        status,
        stdout: o.join().unwrap(),
        stderr: e.join().unwrap(),
    }
}

/// A directory holding an executable `qemu-system-arm` with the given shell script body,
/// and a PATH that finds it first.
fn fake_qemu(body: &str) -> (tempfile::TempDir, String) {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("qemu-system-arm");
    std::fs::write(&exe, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!(
        "{}:{}",
        dir.path().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    (dir, path)
}

fn any_file(dir: &Path) -> PathBuf {
    let p = dir.join("firmware.elf");
    std::fs::write(&p, b"not an ELF").unwrap();
    p
}

/// Before: `brdf query --qemu` blocked forever in `accept()` when QEMU exited at once.
#[test]
fn a_qemu_that_exits_at_once_is_reported_with_its_status_and_stderr() {
    let (dir, path) = fake_qemu("echo \"qemu-system-arm: -chardev: invalid option\" >&2\nexit 1");
    let elf = any_file(dir.path());
    for sub in [&["query", "--angles", "10,10,0"][..], &["check"][..]] {
        let child = brdf()
            .args(sub)
            .args(["--qemu", "--elf", elf.to_str().unwrap()])
            .env("PATH", &path)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let out = finish_within(child, Duration::from_secs(20), "brdf with a QEMU that exits");
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        for want in [
            "invalid option",
            "exit status: 1",
            elf.to_str().unwrap(),
            "qemu-system-arm -machine mps2-an386",
        ] {
            assert!(err.contains(want), "`{want}` missing from: {err}");
        }
    }
}

/// A QEMU that runs but whose firmware never answers: the deadline, not a hang.
#[test]
fn a_firmware_that_never_answers_is_reported_after_the_timeout() {
    let (dir, path) = fake_qemu("exec sleep 60");
    let elf = any_file(dir.path());
    let started = Instant::now();
    let child = brdf()
        .args([
            "query",
            "--qemu",
            "--timeout",
            "1",
            "--angles",
            "10,10,0",
            "--elf",
        ])
        .arg(&elf)
        .env("PATH", &path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = finish_within(child, Duration::from_secs(20), "brdf with a silent QEMU");
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no reply within 1s") && err.contains("QEMU is still running"),
        "{err}"
    );
    assert!(started.elapsed() < Duration::from_secs(15));
}

/// Before: "Connection reset by peer", naming neither the ELF nor what QEMU said.
#[test]
fn a_file_that_is_not_the_firmware_is_named() {
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let elf = any_file(dir.path());
    let child = brdf()
        .args(["query", "--qemu", "--angles", "10,10,0", "--elf"])
        .arg(&elf)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = finish_within(
        child,
        Duration::from_secs(60),
        "brdf with a file that is not an ELF",
    );
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(elf.to_str().unwrap()) && err.contains("QEMU exited"),
        "{err}"
    );
    assert!(
        err.contains("QEMU's standard error: qemu"),
        "QEMU's own message: {err}"
    );
}

/// Inodes of the sockets process `pid` holds.
fn socket_inodes(pid: u32) -> HashSet<u64> {
    let mut out = HashSet::new();
    if let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) {
        for fd in fds.flatten() {
            if let Ok(target) = std::fs::read_link(fd.path()) {
                let t = target.to_string_lossy().into_owned();
                if let Some(n) = t.strip_prefix("socket:[").and_then(|r| r.strip_suffix(']')) {
                    out.extend(n.parse::<u64>().ok());
                }
            }
        }
    }
    out
}

/// Listening sockets of the machine: (inode, TCP port or Unix path).
fn listeners() -> Vec<(u64, Result<u16, String>)> {
    let mut out = Vec::new();
    for table in ["/proc/net/tcp", "/proc/net/tcp6"] {
        for line in std::fs::read_to_string(table).unwrap_or_default().lines().skip(1) {
            let f: Vec<&str> = line.split_whitespace().collect();
            if f.len() > 9 && f[3] == "0A" {
                let port = f[1]
                    .rsplit(':')
                    .next()
                    .and_then(|p| u16::from_str_radix(p, 16).ok());
                if let (Some(port), Ok(inode)) = (port, f[9].parse()) {
                    out.push((inode, Ok(port)));
                }
            }
        }
    }
    for line in std::fs::read_to_string("/proc/net/unix")
        .unwrap_or_default()
        .lines()
        .skip(1)
    {
        let f: Vec<&str> = line.split_whitespace().collect();
        // Flags __SO_ACCEPTCON (0x10000): a listening socket.
        if f.len() > 7 && u32::from_str_radix(f[3], 16).is_ok_and(|x| x & 0x1_0000 != 0) {
            if let Ok(inode) = f[6].parse() {
                out.push((inode, Err(f[7].to_owned())));
            }
        }
    }
    out
}

/// Before: the link listened on a loopback port and took the first connection as the
/// device, so a local process connecting before QEMU could answer in its place. Here such a
/// process watches `brdf query` (whose QEMU starts a second late), connects to every socket
/// it listens on and sends a forged reply: there must be none to connect to, and the value
/// printed must be the firmware's.
#[test]
fn no_local_process_can_pose_as_the_device() {
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    let real = Command::new("sh")
        .args(["-c", "command -v qemu-system-arm"])
        .output()
        .unwrap();
    let real = text(&real.stdout).trim().to_owned();
    let (_dir, path) = fake_qemu(&format!("sleep 1\nexec {real} \"$@\""));
    let mut forged = Vec::new();
    for (tag, resp) in [
        (
            0u8,
            Response::Info {
                build_id: 1,
                format_version: 2,
                active_crc: 0,
                materials: 3,
            },
        ),
        (1, Response::Values(&1234.5f32.to_le_bytes())),
    ] {
        let mut f = vec![0u8; MAX_FRAME];
        let n = encode_response(&resp, tag, &mut f).unwrap();
        forged.extend_from_slice(&f[..n]);
    }
    let mut child = brdf()
        .args(crate::with_firmware(&["query", "--qemu", "--angles", "10,10,0"]))
        .env("PATH", &path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let mut attacked = Vec::new();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() && start.elapsed() < Duration::from_secs(60) {
        let mine = socket_inodes(pid);
        for (inode, addr) in listeners() {
            if !mine.contains(&inode) || attacked.contains(&inode) {
                continue;
            }
            attacked.push(inode);
            match addr {
                Ok(port) => {
                    if let Ok(mut s) = std::net::TcpStream::connect(("127.0.0.1", port)) {
                        let _ = s.write_all(&forged);
                        std::mem::forget(s);
                    }
                }
                Err(p) => {
                    if let Ok(mut s) = std::os::unix::net::UnixStream::connect(p) {
                        let _ = s.write_all(&forged);
                        std::mem::forget(s);
                    }
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let out = finish_within(child, Duration::from_secs(60), "brdf query");
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        attacked.is_empty(),
        "brdf query listened on {} socket(s)",
        attacked.len()
    );
    let p = brdf_core::table1_f32(0).to_vec();
    let m = AnyModel::<f32>::new(ModelKind::Six, &p).unwrap();
    let x = [10f64, 10.0, 0.0].map(|d| d.to_radians() as f32);
    assert_eq!(
        text(&out.stdout).trim(),
        format!("{:.8e}", m.eval_angles(x[0], x[1], x[2]))
    );
}

/// Before: `--timeout -1|nan|inf|1e300` panicked (exit 101), `check --directions 0` printed
/// an empty table. Every numeric flag of every subcommand refuses what is not a duration, a
/// count, a size or an angle as a usage error (exit 2) naming the flag.
#[test]
fn numeric_flags_refuse_what_they_cannot_mean() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d.csv");
    std::fs::write(&data, "theta_i,theta_r,phi,brdf\n0,0,0,0.1\n").unwrap();
    let d = data.to_str().unwrap();
    let bad_seconds = ["-1", "nan", "inf", "1e300", "0", "x", "86401"];
    let bad_counts = ["-1", "1e3", "nan", "x", "18446744073709551616"];
    let cases: Vec<(Vec<&str>, &str, Vec<&str>)> = vec![
        (vec!["check", "--qemu"], "--timeout", bad_seconds.to_vec()),
        (
            vec!["query", "--qemu", "--angles", "0,0,0"],
            "--timeout",
            bad_seconds.to_vec(),
        ),
        (
            vec!["check", "--qemu"],
            "--directions",
            [&bad_counts[..], &["0", "10000001"]].concat(),
        ),
        (
            vec!["check", "--qemu"],
            "--edge",
            [&bad_counts[..], &["1000001"]].concat(),
        ),
        (
            vec!["check", "--serial", "/dev/null"],
            "--baud",
            vec!["0", "-1", "nan"],
        ),
        (vec!["check", "--qemu"], "--seed", vec!["-1", "nan"]),
        (
            vec!["query", "--qemu", "--angles", "0,0,0"],
            "--material",
            vec!["256", "-1"],
        ),
        (
            vec!["fit", d],
            "--chains",
            [&bad_counts[..], &["0", "65"]].concat(),
        ),
        (vec!["fit", d], "--agree", vec!["0", "-1", "nan"]),
        (vec!["fit", d], "--hops", vec!["-1", "65", "nan"]),
        (vec!["fit", d], "--anneal-evals", vec!["0", "-5", "1e9"]),
        (
            vec!["fit", d],
            "--budget-evals",
            vec!["0", "64", "-1", "nan", "10000001"],
        ),
        (vec!["fit", d], "--seed", vec!["-1", "1.5"]),
        (
            vec!["pack", d, "-o", "x.bin"],
            "--table-nodes",
            vec!["0", "1", "100000", "-1"],
        ),
        (
            vec!["pack", d, "-o", "x.bin"],
            "--sequence",
            vec!["-1", "4294967296", "nan"],
        ),
        (vec!["select", d], "--max-theta", vec!["nan", "-1", "91", "inf"]),
        (vec!["select", d], "--max-theta-i", vec!["nan", "-1", "91"]),
        (vec!["select", d], "--max-theta-r", vec!["nan", "95"]),
        (
            vec!["select", d],
            "--budget",
            vec!["-1", "nan", "inf", "0", "0%", ""],
        ),
        (vec!["fit", d], "--loss-scale", vec!["0", "-1", "nan", "inf", ""]),
        (vec!["fit", d], "--channel", vec!["x", "", "rg"]),
        (vec!["fit", d], "--engine", vec!["fast", "", "Full"]),
        (vec!["fit", d], "--residual", vec!["rel", ""]),
        (
            vec!["eval", "--fit", "nonexistent.json", d],
            "--index",
            vec!["-1", "1.5", "nan", ""],
        ),
        (
            vec!["plot", "map", d, "-o", "x.svg"],
            "--theta-i",
            vec!["95", "-1", "nan"],
        ),
        (vec!["bench", "eval"], "--max-theta", vec!["0", "nan", "100"]),
        (vec!["bench", "fit", d], "--seeds", vec!["0", "-1", "10001"]),
        (
            vec!["synth", "--model", "lambert", "--params", "rho0=0.5"],
            "--noise",
            vec!["-1", "nan"],
        ),
    ];
    let mut n = 0;
    for (args, flag, values) in &cases {
        for v in values {
            let out = brdf()
                .args(args)
                .arg(format!("{flag}={v}"))
                .current_dir(dir.path())
                .output()
                .unwrap();
            let err = text(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{args:?} {flag} {v}: {err}");
            assert!(
                err.contains(flag) && !err.contains("panicked"),
                "{args:?} {flag} {v}: {err}"
            );
            n += 1;
        }
    }
    // Steps of `synth` are checked when it runs: a clear error, no panic, no endless loop.
    for (flag, v) in [
        ("--step", "0"),
        ("--step", "nan"),
        ("--phi-step", "-1"),
        ("--phi-step", "inf"),
    ] {
        let child = brdf()
            .args([
                "synth", "--model", "lambert", "--params", "rho0=0.5", "--form", "full",
            ])
            .arg(format!("{flag}={v}"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let out = finish_within(child, Duration::from_secs(20), "synth");
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {v}: {err}");
        assert!(err.contains(flag), "{flag} {v}: {err}");
        n += 1;
    }
    // And values that mean something still get through parsing (they fail later, on the
    // missing firmware, with status 1).
    for (flag, v) in [("--timeout", "0.5"), ("--directions", "1"), ("--edge", "0")] {
        let out = run(&["check", "--qemu", "--elf", "/nonexistent/brdf-fw", flag, v]);
        assert_eq!(out.status.code(), Some(1), "{flag} {v}: {}", text(&out.stderr));
        assert!(text(&out.stderr).contains("/nonexistent/brdf-fw not found"));
    }
    println!("{n} bad numeric arguments refused");
}

/// Before: `query` reformatted numbers (`1e1` became `10`), dropped extra columns, used the
/// first of two `phi` columns, answered NaN and -1e-7 with a device error naming no line and
/// printed 0 for a zenith of 95 that `eval` rejects. Now both share one reader and writer.
#[test]
fn query_prints_what_eval_prints_byte_for_byte() {
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("label,theta_i,note,theta_r,phi\n");
    let odd = [
        "\"a, quoted\",1e1,x,10.000, 0",
        "b,+30,\"y \"\"z\"\"\",45,180",
        "c,-0,,0.0,-30",
        "d,60 ,  spaced  ,75,720",
        "e,90,,0,0",
        "f,0,,90,3.0e2",
        "g,.5,,89.99999,1E-3",
    ];
    for row in odd {
        csv.push_str(row);
        csv.push('\n');
    }
    // More than one chunk of rows.
    for k in 0..5000 {
        csv.push_str(&format!(
            "r{k},{},{k},{},{}\n",
            k % 90,
            (k * 7) % 91,
            (k as f64 * 0.37) % 1100.0 - 400.0
        ));
    }
    let f = dir.path().join("angles.csv");
    std::fs::write(&f, &csv).unwrap();
    let eval = |path: &Path| {
        run(&[
            "eval",
            "--model",
            "six",
            "--params",
            &KHAKI,
            "--precision",
            "f32",
            path.to_str().unwrap(),
        ])
    };
    let query = |path: &Path| run(&["query", "--qemu", path.to_str().unwrap()]);
    let (e, q) = (eval(&f), query(&f));
    assert!(e.status.success(), "{}", text(&e.stderr));
    assert!(q.status.success(), "{}", text(&q.stderr));
    assert_eq!(e.stdout.len(), q.stdout.len());
    assert!(e.stdout == q.stdout, "query and eval --precision f32 differ");
    assert!(
        text(&q.stdout).starts_with("label,theta_i,note,theta_r,phi,brdf\n\"a, quoted\",1e1,x,10.000, 0,")
    );

    // Files eval refuses: query refuses them with the same message, and prints nothing.
    let bad = [
        ("dup.csv", "theta_i,theta_r,phi,phi\n0,0,0,0\n"),
        ("nan.csv", "theta_i,theta_r,phi\n0,0,0\nnan,0,0\n"),
        ("neg.csv", "theta_i,theta_r,phi\n0,-1e-7,0\n"),
        ("tiny.csv", "theta_i,theta_r,phi\n0,-1e-300,0\n"),
        ("high.csv", "theta_i,theta_r,phi\n95,0,0\n"),
        ("word.csv", "theta_i,theta_r,phi\n10,abc,0\n"),
        ("short.csv", "theta_i,theta_r,phi\n0,0\n"),
        ("clash.csv", "theta_i,theta_r,phi,brdf\n0,0,0,1\n"),
        ("missing.csv", "theta_i,phi\n0,0\n"),
    ];
    for (name, body) in bad {
        let p = dir.path().join(name);
        std::fs::write(&p, body).unwrap();
        let (e, q) = (eval(&p), query(&p));
        assert!(!e.status.success() && !q.status.success(), "{name}");
        assert_eq!(text(&q.stderr), text(&e.stderr), "{name}");
        assert!(text(&e.stderr).contains(name), "{name}: {}", text(&e.stderr));
        assert!(q.stdout.is_empty() && e.stdout.is_empty(), "{name}");
    }
    // The single-direction form is checked the same way.
    for angles in ["95,0,0", "0,nan,0", "0,-1e-7,0", "1,2"] {
        let q = run(&["query", "--qemu", "--angles", angles]);
        assert_eq!(q.status.code(), Some(1), "{angles}");
        assert!(
            text(&q.stderr).contains("--angles"),
            "{angles}: {}",
            text(&q.stderr)
        );
    }
}

/// Before: `eval` held every output row in memory and wrote them at the end (358 MB for a
/// 200 MB input). Now a chunk of rows is written as soon as it is evaluated: with its input
/// still open, `eval` has already written the first 4,096 rows.
#[test]
fn eval_writes_as_it_reads() {
    let mut child = brdf()
        .args(["eval", "--model", "six", "--params", &KHAKI, "/dev/stdin"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut input = child.stdin.take().unwrap();
    let mut rows = String::from("theta_i,theta_r,phi\n");
    for k in 0..5000 {
        rows.push_str(&format!("{},{},{}\n", k % 80, (k * 3) % 80, k % 360));
    }
    input.write_all(rows.as_bytes()).unwrap();
    input.flush().unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines() {
            if line.is_err() || tx.send(()).is_err() {
                break;
            }
        }
    });
    // Header and one chunk, while the input stays open.
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut seen = 0;
    while seen < 1 + 4096 {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(()) => seen += 1,
            Err(_) => {
                let _ = child.kill();
                panic!("only {seen} lines written while the input was open: eval does not stream");
            }
        }
    }
    drop(input);
    while rx.recv_timeout(Duration::from_secs(30)).is_ok() {
        seen += 1;
    }
    reader.join().unwrap();
    assert!(child.wait().unwrap().success());
    assert_eq!(seen, 5001);
}

/// A bad row after the first chunk: the chunks before it are written whole, nothing after.
#[test]
fn a_bad_row_stops_eval_after_whole_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = String::from("theta_i,theta_r,phi\n");
    for k in 0..5000 {
        if k == 4500 {
            rows.push_str("10,95,0\n");
        } else {
            rows.push_str(&format!("{},{},{}\n", k % 80, (k * 3) % 80, k % 360));
        }
    }
    let f = dir.path().join("late.csv");
    std::fs::write(&f, rows).unwrap();
    let out = run(&["eval", "--model", "six", "--params", &KHAKI, f.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("late.csv: line 4502: column theta_r: zenith 95 deg"));
    assert_eq!(text(&out.stdout).lines().count(), 1 + 4096);
}

/// Before: OS errors appeared twice in a message, and -1e-300 printed as 300 digits.
#[test]
fn messages_say_each_thing_once_and_numbers_briefly() {
    let os = "No such file or directory";
    for args in [
        &[
            "eval",
            "--model",
            "six",
            "--params",
            KHAKI.as_str(),
            "/nonexistent/a.csv",
        ][..],
        &["fit", "/nonexistent/a.csv"][..],
        &["pack", "/nonexistent/a.json", "-o", "/tmp/x.bin"][..],
        &["query", "--qemu", "/nonexistent/a.csv"][..],
    ] {
        let err = text(&run(args).stderr);
        assert_eq!(err.matches(os).count(), 1, "{args:?}: {err}");
        assert!(err.contains("/nonexistent/a."), "{args:?}: {err}");
    }
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("t.csv");
    std::fs::write(&f, "theta_i,theta_r,phi\n0,-1e-300,0\n").unwrap();
    let err = text(
        &run(&[
            "eval",
            "--model",
            "lambert",
            "--params",
            "rho0=1",
            f.to_str().unwrap(),
        ])
        .stderr,
    );
    assert!(err.contains("zenith -1e-300 deg") && err.len() < 200, "{err}");
    let params = "kb=0.2,kr=2,b=-3,a=0.5,kd=-1e-300,c=1";
    let err = text(&run(&["eval", "--model", "six", "--params", params, f.to_str().unwrap()]).stderr);
    assert!(
        err.contains("kd = -1e-300 is out of range") && err.len() < 200,
        "{err}"
    );
    let data = dir.path().join("d.csv");
    std::fs::write(&data, "theta_i,theta_r,phi,brdf\n0,-1e-300,0,0.1\n").unwrap();
    let err = text(&run(&["fit", data.to_str().unwrap()]).stderr);
    assert!(err.contains("-1e-300 is outside") && err.len() < 200, "{err}");
}

fn fit_json(dir: &Path, name: &str, model: &str, params: &[(&str, f64)]) -> PathBuf {
    let p = dir.join(name);
    let body: Vec<String> = params.iter().map(|(k, v)| format!("\"{k}\":{v:e}")).collect();
    std::fs::write(
        &p,
        format!("{{\"model\":\"{model}\",\"params\":{{{}}}}}", body.join(",")),
    )
    .unwrap();
    p
}

/// Before: `kr = 1e-6` packed without tables but not with them, `check --blob` refused it
/// with a message naming neither file nor material, and `pack` accepted `kb = 3e38`,
/// `b = -1e30`, `a = 1e30`. Now pack (with and without tables) accepts a parameter exactly
/// when the core's ranges do, in f32 as in f64, and names the file and the fit when not.
#[test]
fn pack_applies_the_core_ranges_with_and_without_tables() {
    let dir = tempfile::tempdir().unwrap();
    let six = ModelKind::Six.ranges();
    let base = [
        ("kb", 0.25),
        ("kr", 21.8),
        ("b", -27.6),
        ("a", 0.67),
        ("kd", 0.37),
        ("c", 1.2),
    ];
    let mut checked = 0;
    for (j, r) in six.iter().enumerate() {
        let edges = [
            f64::from(r.min.next_down()),
            f64::from(r.min),
            f64::from(r.min.next_up()),
            f64::from(r.max.next_down()),
            f64::from(r.max),
            f64::from(r.max.next_up()),
        ];
        for v in edges.into_iter().chain([3e38, -1e30, 1e30, 1e-6]) {
            let mut p = base;
            p[j].1 = v;
            let json = fit_json(dir.path(), "f.json", "six", &p);
            let blob = dir.path().join("f.bin");
            let in_range = r.contains(v) && r.contains(v as f32);
            for tables in [false, true] {
                // Tables hold mu^c on [0, 1], unbounded for c < 0: they refuse it.
                let ok = in_range && !(tables && r.name == "c" && v < 0.0);
                let mut args = vec!["pack", json.to_str().unwrap(), "-o", blob.to_str().unwrap()];
                if tables {
                    args.extend(["--table-nodes", "64"]);
                }
                let out = run(&args);
                let err = text(&out.stderr);
                assert_eq!(
                    out.status.success(),
                    ok,
                    "{} = {v:e}, tables {tables}: {err}",
                    r.name
                );
                if !ok {
                    assert!(err.contains("f.json: fit 0") && err.contains(r.name), "{err}");
                }
                checked += 1;
            }
        }
    }
    println!("{checked} pack runs at the parameter bounds agree with the core's ranges");
}

/// The fitter's search box lies inside the ranges, but for the linear weights' upper
/// bounds (there is none); `check --blob`
/// takes a blob at the corners of the ranges (it may judge its accuracy, but never refuses
/// its parameters); and a blob beyond them (`kr = 1e-6` in f32, which the device used to
/// accept while `check` refused it in f64 naming neither file nor material) is refused by
/// name before anything is loaded.
#[test]
fn fits_pack_and_check_takes_blobs_at_the_range_corners() {
    use brdf_fit::kernel::to_natural;
    use brdf_fit::problem::bounds;
    for kind in ModelKind::ALL {
        let (mut lo, hi) = bounds(kind);
        let n = kind.param_count();
        for brightening in [false, true] {
            if brightening && matches!(kind, ModelKind::Six | ModelKind::SixCos2) {
                lo[5] = brdf_fit::problem::BRIGHTENING_C_MIN;
            }
            for q in [lo, hi] {
                let p = to_natural(kind, &q[..n]);
                for (j, (r, v)) in kind.ranges().iter().zip(&p[..n]).enumerate() {
                    // The linear weights are bounded only below (a bound above would make a
                    // fit depend on the data's units); a fit beyond their range is named in
                    // its report (`outside_ranges`) and refused by pack.
                    let linear = kind.linear_params().contains(&j);
                    if linear && v.is_infinite() {
                        continue;
                    }
                    assert!(r.contains(*v), "{kind:?} {} = {v}", r.name);
                }
            }
        }
    }
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let six = ModelKind::Six.ranges();
    let corner: Vec<(&str, f64)> = ["kb", "kr", "b", "a", "kd", "c"]
        .iter()
        .zip(six)
        .map(|(n, r)| (*n, f64::from(if *n == "b" { r.min } else { r.max })))
        .collect();
    let json = fit_json(dir.path(), "corner.json", "six", &corner);
    let blob = dir.path().join("corner.bin");
    let pack = run(&["pack", json.to_str().unwrap(), "-o", blob.to_str().unwrap()]);
    assert!(pack.status.success(), "{}", text(&pack.stderr));
    let out = run(&[
        "check",
        "--qemu",
        "--blob",
        blob.to_str().unwrap(),
        "--directions",
        "200",
        "--edge",
        "20",
        "--json",
    ]);
    let err = text(&out.stderr);
    assert!(!err.contains("out of range") && !err.contains("refused"), "{err}");
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows.as_array().unwrap().len(), 5, "{err}");

    let mut tiny = brdf_wire::blob::table1_blob();
    tiny.materials.truncate(2);
    tiny.materials[1].params[1] = 1e-6;
    let mut buf = [0u8; brdf_wire::blob::MAX_BLOB_LEN];
    let n = tiny.encode(&mut buf).unwrap();
    let path = dir.path().join("tiny-kr.bin");
    std::fs::write(&path, &buf[..n]).unwrap();
    let out = run(&[
        "check",
        "--qemu",
        "--blob",
        path.to_str().unwrap(),
        "--directions",
        "10",
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("tiny-kr.bin: material 1: parameters out of range"),
        "{err}"
    );
}

/// Before: `brdf fit` fitted six parameters to ten copies of one measurement.
#[test]
fn fit_refuses_repeated_directions() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("same.csv");
    let mut body = String::from("theta_i,theta_r,phi,brdf\n");
    for _ in 0..10 {
        body.push_str("10,20,180,0.1\n");
    }
    for k in 0..4 {
        body.push_str(&format!("10,{},0,0.1\n", 30 + k));
    }
    std::fs::write(&f, body).unwrap();
    let out = run(&["fit", f.to_str().unwrap()]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("5 distinct direction(s) cannot determine 6 parameters"),
        "{err}"
    );
    let out = run(&["fit", "--model", "lambert", f.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
}

/// `/dev/zero` read as data grew without bound until the process aborted, and a named pipe
/// was waited on forever: every input a command reads is refused unless it is a regular file,
/// naming it, within seconds.
#[test]
fn devices_and_pipes_are_refused_as_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.csv");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let mesh = format!("{}/../../data/scenes/target.obj", env!("CARGO_MANIFEST_DIR"));
    let scene = |key: &str, value: &str| {
        let p = dir.path().join(format!("{key}.toml"));
        std::fs::write(
            &p,
            format!(
                "mesh = \"{mesh}\"\n\n[[material]]\npart = \"*\"\n{key} = \"{value}\"\n\n[sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 10, 5]\nelevation_deg = [0, 1, 1]\n",
            ),
        )
        .unwrap();
        p.display().to_string()
    };
    let angles = dir.path().join("angles.csv");
    std::fs::write(&angles, "theta_i,theta_r,phi\n10,10,0\n").unwrap();
    let angles = angles.display().to_string();
    for input in ["/dev/zero", fifo.to_str().unwrap()] {
        let fit_scene = scene("fit", input);
        let blob_scene = scene("blob", input);
        for args in [
            vec!["fit", input],
            vec!["select", input],
            vec!["pack", input, "-o", "/dev/null"],
            vec!["eval", "--fit", input, &angles],
            vec!["eval", "--model", "lambert", "--params", "rho0=0.5", "/dev/zero"],
            vec!["scene", "lrcs", input],
            vec!["scene", "lrcs", &fit_scene],
            vec!["scene", "lrcs", &blob_scene],
        ] {
            let child = brdf()
                .args(&args)
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap();
            let out = finish_within(child, Duration::from_secs(20), &format!("{args:?}"));
            let err = text(&out.stderr);
            assert!(
                !out.status.success() && err.contains("not a regular file"),
                "{args:?}: {err}"
            );
        }
    }
    // `brdf eval` streams its directions, from a pipe too (`/dev/stdin`), but an endless line
    // is an error, not unbounded memory.
    let mut child = brdf()
        .args(["eval", "--model", "lambert", "--params", "rho0=0.5", "/dev/stdin"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut input = child.stdin.take().unwrap();
    let feeder = std::thread::spawn(move || {
        let zeros = vec![b'0'; 1 << 16];
        for _ in 0..64 {
            if input.write_all(&zeros).is_err() {
                break;
            }
        }
    });
    let out = finish_within(child, Duration::from_secs(20), "eval of an endless line");
    feeder.join().unwrap();
    let err = text(&out.stderr);
    assert!(
        !out.status.success() && err.contains("a line longer than"),
        "{err}"
    );
}

/// Runs `brdf args` with standard error a pipe whose reading end is already closed (as in
/// `brdf ... 2>&1 >/dev/null | head -c1` once `head` has left): every write to it fails.
fn with_stderr_closed(args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    brdf()
        .args(crate::with_firmware(args))
        .stdout(Stdio::piped())
        .stderr(Stdio::from(writer))
        .output()
        .unwrap()
}

/// Before: every `eprintln!` panicked on a closed standard error (exit 101): `brdf pack`
/// after writing its blob, `brdf fit` at its first warning, with nothing on standard output.
/// Now lines for standard error are dropped and the command goes on; an error still exits 1.
#[test]
fn a_closed_standard_error_loses_the_messages_not_the_command() {
    let dir = tempfile::tempdir().unwrap();
    let fit = fit_json(dir.path(), "p.json", "lambert", &[("rho0", 0.5)]);
    let blob = dir.path().join("x.blob");
    let out = with_stderr_closed(&[
        "pack",
        fit.to_str().unwrap(),
        "-o",
        blob.to_str().unwrap(),
        "--table-nodes",
        "256",
    ]);
    assert_eq!(out.status.code(), Some(0), "pack");
    assert!(std::fs::metadata(&blob).unwrap().len() > 0);

    // A fit whose skipped lines are listed on standard error before its report.
    let data = dir.path().join("d.csv");
    let mut rows = String::from("theta_i,theta_r,phi,brdf\n");
    for (ti, tr) in [(0, 10), (10, 20), (20, 30), (30, 40)] {
        rows.push_str(&format!("{ti},{tr},0,0.15\n"));
    }
    rows.push_str("10,20,0,abc\n");
    std::fs::write(&data, rows).unwrap();
    let data = data.to_str().unwrap();
    let out = with_stderr_closed(&["fit", "--model", "lambert", "--skip-invalid", data]);
    assert_eq!(out.status.code(), Some(0), "fit");
    let report = text(&out.stdout);
    assert!(report.contains("rho0"), "{report}");

    let out = with_stderr_closed(&["fit", "/nonexistent/a.csv"]);
    assert_eq!(out.status.code(), Some(1), "a failing command");
}
