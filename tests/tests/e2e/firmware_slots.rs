//! The firmware's flash slots under QEMU: COMMIT survives a restart, a corrupted slot falls
//! back to the other and then to the built-in default, a torn write changes nothing, and the
//! boot log (defmt, decoded on the host with the firmware ELF) matches the golden files in
//! `tests/golden/`. `BRDF_BLESS=1` rewrites the golden files from this run.

use std::path::Path;

use brdf_link::{decode_defmt, Link, LinkError, Qemu, FLASH_IMAGE};
use brdf_tests::qemu::firmware;
use brdf_wire::blob::{table1_blob, Blob, MAX_BLOB_LEN};
use brdf_wire::frame::ErrorCode;
use brdf_wire::slots::SLOT_IMAGE_LEN;

fn blob(sequence: u32, materials: &[usize]) -> Vec<u8> {
    let all = table1_blob();
    let mut b = Blob {
        sequence,
        materials: heapless::Vec::new(),
    };
    for &i in materials {
        b.materials.push(all.materials[i]).unwrap();
    }
    let mut buf = [0u8; MAX_BLOB_LEN];
    let n = b.encode(&mut buf).unwrap();
    buf[..n].to_vec()
}

fn crc(blob: &[u8]) -> u32 {
    brdf_wire::blob::blob_crc(blob)
}

/// Boots QEMU in `dir`, returns (INFO's active CRC and material count, decoded boot log).
fn boot(elf: &Path, dir: &Path) -> (u32, u8, Vec<String>) {
    let mut dev = Link::new(Qemu::spawn_in(elf, dir).unwrap());
    let (_, _, active, materials) = dev.info().unwrap();
    let log = dev.into_transport().stop();
    (active, materials, decode_defmt(elf, &log).unwrap())
}

fn golden(name: &str, lines: &[String]) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("golden").join(name);
    let text = lines.join("\n") + "\n";
    if std::env::var("BRDF_BLESS").as_deref() == Ok("1") {
        std::fs::write(&path, &text).unwrap();
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(text, want, "boot log differs from {}", path.display());
}

fn flip(dir: &Path, at: usize) {
    let path = dir.join(FLASH_IMAGE);
    let mut image = std::fs::read(&path).unwrap();
    image[at] ^= 0x40;
    std::fs::write(&path, image).unwrap();
}

#[test]
fn commit_persists_and_each_fault_falls_back() {
    let Some(elf) = firmware() else { return };
    let dir = tempfile::tempdir().unwrap();
    let default_crc = crc(&blob(0, &[0, 1, 2]));

    // Fresh flash: both slots empty, the built-in default.
    let (active, materials, log) = boot(&elf, dir.path());
    assert_eq!((active, materials), (default_crc, 3));
    golden("boot-empty.txt", &log);

    // COMMIT sequence 5 (khaki) to A, then 6 (yellow, white) to B; a stale one is refused.
    let (b5, b6) = (blob(5, &[0]), blob(6, &[1, 2]));
    let mut dev = Link::new(Qemu::spawn_in(&elf, dir.path()).unwrap());
    assert_eq!(dev.commit(&b5).unwrap(), crc(&b5));
    assert!(matches!(
        dev.commit(&b5),
        Err(LinkError::Device(ErrorCode::StaleSequence))
    ));
    assert!(matches!(
        dev.commit(&b6[..b6.len() - 1]),
        Err(LinkError::Device(ErrorCode::InvalidBlob))
    ));
    assert_eq!(dev.commit(&b6).unwrap(), crc(&b6));
    assert_eq!(dev.info().unwrap().2, crc(&b6));
    // A LOAD only changes RAM.
    dev.load(&blob(9, &[2])).unwrap();
    let log = decode_defmt(&elf, &dev.into_transport().stop()).unwrap();
    assert!(
        log.iter().any(|l| l.contains("commit: slot A, sequence 5")),
        "{log:?}"
    );
    assert!(
        log.iter().any(|l| l.contains("commit: slot B, sequence 6")),
        "{log:?}"
    );
    assert!(
        log.iter()
            .any(|l| l.contains("commit refused: sequence 5 not newer than 5")),
        "{log:?}"
    );

    // Restart on the same flash: the newest slot (B, sequence 6) is active.
    let (active, materials, log) = boot(&elf, dir.path());
    assert_eq!((active, materials), (crc(&b6), 2));
    golden("boot-two-slots.txt", &log);

    // A torn COMMIT into the inactive slot A (blob bytes of sequence 7 written, length word
    // still erased) changes nothing.
    let b7 = blob(7, &[0, 1]);
    let path = dir.path().join(FLASH_IMAGE);
    let mut image = std::fs::read(&path).unwrap();
    image[..SLOT_IMAGE_LEN].fill(0xFF);
    image[4..4 + b7.len()].copy_from_slice(&b7);
    std::fs::write(&path, &image).unwrap();
    let (active, _, log) = boot(&elf, dir.path());
    assert_eq!(active, crc(&b6));
    assert!(log.iter().any(|l| l == "INFO boot: slot A empty"), "{log:?}");

    // COMMIT 7: it goes to A, the slot that is not the newest valid one.
    let mut dev = Link::new(Qemu::spawn_in(&elf, dir.path()).unwrap());
    assert_eq!(dev.commit(&blob(7, &[0])).unwrap(), crc(&blob(7, &[0])));
    drop(dev);
    // Now A holds 7 (newest), B holds 6. Corrupt A's blob: B (6) is used.
    flip(dir.path(), 4 + 20);
    let (active, materials, log) = boot(&elf, dir.path());
    assert_eq!((active, materials), (crc(&b6), 2));
    golden("boot-fallback.txt", &log);

    // Corrupt B's too: the built-in default.
    flip(dir.path(), SLOT_IMAGE_LEN + 4 + 20);
    let (active, materials, log) = boot(&elf, dir.path());
    assert_eq!((active, materials), (default_crc, 3));
    golden("boot-both-invalid.txt", &log);
}
