//! The minimal embedding example (`firmware/embed-example`) runs under QEMU and answers its one
//! query exactly as the host's f32 path does, within the f32 tolerance of the f64 model.

use std::process::Stdio;
use std::time::{Duration, Instant};

use brdf_core::tolerance::F32_MAX_REL;
use brdf_core::{Brdf, SixParam, SixParams};

#[test]
fn embed_example_answers_like_the_host() {
    let Some(elf) = brdf_tests::qemu::program("embed-example") else {
        return;
    };
    let mut child = brdf_link::qemu_command()
        .arg("-kernel")
        .arg(&elf)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("qemu-system-arm starts");
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            child.kill().unwrap();
            panic!("embed-example did not exit within 60 s under QEMU");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: f32 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();

    // The same constant as the example's source.
    let khaki = brdf_core::table1_f32(0);
    let host = SixParam::new(SixParams::from_array(khaki)).unwrap();
    let (ci, cr, cp) = (0.866_025_4_f32, 0.5_f32, -1.0_f32);
    assert_eq!(printed.to_bits(), host.eval_cosines(ci, cr, cp).to_bits());

    let exact = SixParam::new(SixParams::from_array(khaki.map(f64::from))).unwrap();
    let reference = exact.eval_cosines(f64::from(ci), f64::from(cr), f64::from(cp));
    let rel = (f64::from(printed) - reference).abs() / reference;
    assert!(rel <= F32_MAX_REL, "{printed} against {reference}: {rel:e}");
}
