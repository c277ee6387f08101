//! The model-comparison report in docs/ regenerates bit for bit from one command.

use std::path::PathBuf;

#[test]
fn report_regenerates_bit_for_bit() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let committed = root.join("docs/comparison");
    let dir = tempfile::tempdir().unwrap();
    let out = crate::brdf_command()
        .args(["report", "--data"])
        .arg(root.join("data/measured"))
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut names: Vec<_> = std::fs::read_dir(&committed)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    let mut made: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    made.sort();
    assert_eq!(names, made, "the same files");
    assert!(
        names.len() >= 2 + 6 * 6,
        "table, results and 6 figures per dataset"
    );
    for n in names {
        let a = std::fs::read(committed.join(&n)).unwrap();
        let b = std::fs::read(dir.path().join(&n)).unwrap();
        assert!(
            a == b,
            "{} differs from a fresh `brdf report`",
            n.to_string_lossy()
        );
    }
}
