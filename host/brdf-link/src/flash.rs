//! Flashing a parameter blob into a device's inactive slot (`brdf flash`).
//!
//! The slot addresses come from the firmware ELF's symbols (`BRDF_SLOT_A`, `BRDF_SLOT_B`,
//! `BRDF_SLOT_SIZE`, defined by its memory map). [`flash_blob`] reads both slots through a
//! [`SlotTarget`], plans the write with the firmware COMMIT's own function
//! ([`brdf_wire::slots::plan_commit`]: never the newest valid slot, only a blob with a newer
//! sequence number), writes the slot image,
//! reads it back, and finally resets the device so that it boots from the new slot. An
//! interruption at any point leaves the newest valid slot as it was.
//!
//! [`SlotTarget`] is implemented by [`crate::probe::ProbeTarget`] (probe-rs) and, in the
//! tests, by a fake flash that can be cut off mid-write.

use std::path::Path;

use brdf_wire::slots::{plan_commit, read_slot, SlotId, SlotState, SLOT_IMAGE_LEN};

/// Why flashing failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FlashError {
    /// The ELF could not be read or lacks the slot symbols.
    #[error("{0}")]
    Elf(String),
    /// The blob may not be written (does not decode, or its sequence is not new).
    #[error("refused: {0}")]
    Refused(brdf_wire::slots::CommitError),
    /// The probe or target failed.
    #[error("target: {0}")]
    Target(String),
    /// The slot read back differs from what was written.
    #[error("slot {0} read back differently from what was written")]
    Verify(&'static str),
}

/// Slot addresses of a firmware build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotMap {
    /// Slot A's address.
    pub a: u64,
    /// Slot B's address.
    pub b: u64,
    /// Bytes reserved for each slot (one erase unit or more).
    pub size: u64,
}

impl SlotMap {
    /// Reads `BRDF_SLOT_A`, `BRDF_SLOT_B` and `BRDF_SLOT_SIZE` from the ELF at `elf`.
    pub fn from_elf(elf: &Path) -> Result<SlotMap, FlashError> {
        use object::{Object, ObjectSymbol};
        let data = std::fs::read(elf).map_err(|e| FlashError::Elf(format!("{}: {e}", elf.display())))?;
        let file =
            object::File::parse(&*data).map_err(|e| FlashError::Elf(format!("{}: {e}", elf.display())))?;
        let find = |name: &str| {
            file.symbols()
                .find(|s| s.name() == Ok(name))
                .map(|s| s.address())
                .ok_or_else(|| {
                    FlashError::Elf(format!(
                        "{}: no symbol {name} (not a brdf-fw build with parameter slots)",
                        elf.display()
                    ))
                })
        };
        let map = SlotMap {
            a: find("BRDF_SLOT_A")?,
            b: find("BRDF_SLOT_B")?,
            size: find("BRDF_SLOT_SIZE")?,
        };
        if map.size < SLOT_IMAGE_LEN as u64 || map.a.abs_diff(map.b) < map.size {
            return Err(FlashError::Elf(format!(
                "{}: slot symbols are inconsistent: {map:?}",
                elf.display()
            )));
        }
        Ok(map)
    }

    /// The address of `slot`.
    pub fn address(&self, slot: SlotId) -> u64 {
        match slot {
            SlotId::A => self.a,
            SlotId::B => self.b,
        }
    }
}

/// A device's memory as a flasher sees it.
pub trait SlotTarget {
    /// Reads `buf.len()` bytes at `address`.
    fn read(&mut self, address: u64, buf: &mut [u8]) -> Result<(), FlashError>;
    /// Erases the erase units covering `[address, address + data.len())` and programs
    /// `data` at `address`.
    fn program(&mut self, address: u64, data: &[u8]) -> Result<(), FlashError>;
    /// Resets the device (it boots from its slots).
    fn reset(&mut self) -> Result<(), FlashError>;
}

/// What [`flash_blob`] found and did (or, with `dry_run`, would do).
#[derive(Clone, Debug, PartialEq)]
pub struct FlashPlan {
    /// State of slot A before.
    pub a: SlotState,
    /// State of slot B before.
    pub b: SlotState,
    /// The slot written.
    pub target: SlotId,
    /// Its address.
    pub address: u64,
    /// The slot image (length word and blob).
    pub image_len: usize,
    /// The blob's sequence number.
    pub sequence: u32,
    /// Nothing was written.
    pub dry_run: bool,
}

impl std::fmt::Display for FlashPlan {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "slot A: {}", self.a)?;
        writeln!(f, "slot B: {}", self.b)?;
        write!(
            f,
            "{} {} bytes (blob sequence {}) to slot {} at {:#010x}{}",
            if self.dry_run { "would write" } else { "wrote" },
            self.image_len,
            self.sequence,
            self.target.name(),
            self.address,
            if self.dry_run {
                ", then verify and reset"
            } else {
                ", verified, device reset"
            }
        )
    }
}

/// Writes `blob` into the inactive slot of the device behind `target`, verifies it, and
/// resets the device; with `dry_run` only reads the slots and returns the plan.
pub fn flash_blob<T: SlotTarget + ?Sized>(
    target: &mut T,
    map: &SlotMap,
    blob: &[u8],
    dry_run: bool,
) -> Result<FlashPlan, FlashError> {
    let mut images = [vec![0u8; SLOT_IMAGE_LEN], vec![0u8; SLOT_IMAGE_LEN]];
    target.read(map.a, &mut images[0])?;
    target.read(map.b, &mut images[1])?;
    let mut image = vec![0u8; SLOT_IMAGE_LEN];
    let commit = plan_commit(&images[0], &images[1], blob, &mut image).map_err(FlashError::Refused)?;
    image.truncate(commit.image_len);
    let plan = FlashPlan {
        a: commit.a,
        b: commit.b,
        target: commit.target,
        address: map.address(commit.target),
        image_len: commit.image_len,
        sequence: commit.sequence(),
        dry_run,
    };
    if dry_run {
        return Ok(plan);
    }
    target.program(plan.address, &image)?;
    let mut back = vec![0u8; image.len()];
    target.read(plan.address, &mut back)?;
    if back != image || !matches!(read_slot(&back).0, SlotState::Valid { .. }) {
        return Err(FlashError::Verify(plan.target.name()));
    }
    target.reset()?;
    Ok(plan)
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_wire::blob::{table1_blob, MAX_BLOB_LEN};
    use brdf_wire::slots::select;

    /// Flash with erase units of `unit` bytes; `budget` bytes may be programmed before the
    /// "power" fails (the rest of that program call is lost).
    struct FakeFlash {
        mem: Vec<u8>,
        unit: usize,
        budget: usize,
        resets: usize,
        writes: usize,
    }

    impl FakeFlash {
        fn new(unit: usize) -> Self {
            FakeFlash {
                mem: vec![0xFF; 0x1_0000],
                unit,
                budget: usize::MAX,
                resets: 0,
                writes: 0,
            }
        }
    }

    impl SlotTarget for FakeFlash {
        fn read(&mut self, address: u64, buf: &mut [u8]) -> Result<(), FlashError> {
            let a = address as usize;
            buf.copy_from_slice(&self.mem[a..a + buf.len()]);
            Ok(())
        }
        fn program(&mut self, address: u64, data: &[u8]) -> Result<(), FlashError> {
            self.writes += 1;
            let a = address as usize;
            let start = a / self.unit * self.unit;
            let end = (a + data.len()).div_ceil(self.unit) * self.unit;
            self.mem[start..end].fill(0xFF);
            for (i, &d) in data.iter().enumerate() {
                if self.budget == 0 {
                    return Err(FlashError::Target("power lost".into()));
                }
                self.budget -= 1;
                self.mem[a + i] &= d;
            }
            Ok(())
        }
        fn reset(&mut self) -> Result<(), FlashError> {
            self.resets += 1;
            Ok(())
        }
    }

    const MAP: SlotMap = SlotMap {
        a: 0x2000,
        b: 0x6000,
        size: 0x4000,
    };

    fn blob(sequence: u32) -> Vec<u8> {
        let mut b = table1_blob();
        b.sequence = sequence;
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = b.encode(&mut buf).unwrap();
        buf[..n].to_vec()
    }

    fn states(f: &mut FakeFlash) -> (SlotState, SlotState) {
        let mut a = vec![0; SLOT_IMAGE_LEN];
        let mut b = vec![0; SLOT_IMAGE_LEN];
        f.read(MAP.a, &mut a).unwrap();
        f.read(MAP.b, &mut b).unwrap();
        (read_slot(&a).0, read_slot(&b).0)
    }

    #[test]
    fn alternates_slots_verifies_and_resets() {
        let mut f = FakeFlash::new(0x4000);
        let p = flash_blob(&mut f, &MAP, &blob(1), false).unwrap();
        assert_eq!((p.target, p.address, f.resets), (SlotId::A, 0x2000, 1));
        let p = flash_blob(&mut f, &MAP, &blob(2), false).unwrap();
        assert_eq!(p.target, SlotId::B);
        let p = flash_blob(&mut f, &MAP, &blob(3), false).unwrap();
        assert_eq!(p.target, SlotId::A);
        let (a, b) = states(&mut f);
        assert_eq!((a.sequence(), b.sequence()), (Some(3), Some(2)));
        assert_eq!(select(&a, &b), Some(SlotId::A));
        assert!(p
            .to_string()
            .contains("wrote 108 bytes (blob sequence 3) to slot A at 0x00002000"));
    }

    #[test]
    fn dry_run_writes_nothing_and_stale_or_bad_blobs_are_refused() {
        let mut f = FakeFlash::new(0x4000);
        flash_blob(&mut f, &MAP, &blob(4), false).unwrap();
        let before = f.mem.clone();
        let p = flash_blob(&mut f, &MAP, &blob(5), true).unwrap();
        assert_eq!((p.target, p.dry_run), (SlotId::B, true));
        assert!(p.to_string().starts_with("slot A: valid, sequence 4"));
        assert!(p.to_string().contains("would write"));
        assert_eq!((f.mem == before, f.writes, f.resets), (true, 1, 1));
        assert!(matches!(
            flash_blob(&mut f, &MAP, &blob(4), false),
            Err(FlashError::Refused(brdf_wire::slots::CommitError::Stale {
                sequence: 4,
                active: 4
            }))
        ));
        let b = blob(9);
        assert!(matches!(
            flash_blob(&mut f, &MAP, &b[..b.len() - 2], false),
            Err(FlashError::Refused(_))
        ));
        assert_eq!(f.mem, before);
    }

    #[test]
    fn sequence_numbers_wrap_without_locking_the_slots() {
        let mut f = FakeFlash::new(0x4000);
        for sequence in [0xFFFF_FFFE_u32, 0xFFFF_FFFF, 0, 1] {
            let p = flash_blob(&mut f, &MAP, &blob(sequence), false).unwrap();
            let (a, b) = states(&mut f);
            assert_eq!(select(&a, &b), Some(p.target), "sequence {sequence:#x}");
            let (a, b) = (a.sequence(), b.sequence());
            assert!(a == Some(sequence) || b == Some(sequence));
        }
        // The one before the newest is stale.
        assert!(matches!(
            flash_blob(&mut f, &MAP, &blob(0), false),
            Err(FlashError::Refused(brdf_wire::slots::CommitError::Stale {
                sequence: 0,
                active: 1
            }))
        ));
    }

    #[test]
    fn an_interruption_at_any_byte_keeps_the_previous_parameters() {
        let image_len = blob(2).len() + 4;
        for cut in (0..image_len).step_by(7) {
            let mut f = FakeFlash::new(0x4000);
            flash_blob(&mut f, &MAP, &blob(1), false).unwrap();
            flash_blob(&mut f, &MAP, &blob(2), false).unwrap();
            // The third write goes to A (B holds the newest, 2); cut it short.
            f.budget = cut;
            assert!(flash_blob(&mut f, &MAP, &blob(3), false).is_err());
            let (a, b) = states(&mut f);
            assert_eq!(
                select(&a, &b),
                Some(SlotId::B),
                "cut after {cut} bytes: {a:?} {b:?}"
            );
            assert_eq!(b.sequence(), Some(2));
            // And the next attempt succeeds.
            f.budget = usize::MAX;
            assert_eq!(
                flash_blob(&mut f, &MAP, &blob(3), false).unwrap().target,
                SlotId::A
            );
        }
    }

    #[test]
    fn slot_symbols_come_from_the_elf_and_missing_ones_are_named() {
        let err = SlotMap::from_elf(Path::new("/nonexistent/brdf-fw")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/brdf-fw"));
        // Any ELF without the symbols (this test binary) is refused by name.
        let me = std::env::current_exe().unwrap();
        let err = SlotMap::from_elf(&me).unwrap_err();
        assert!(err.to_string().contains("no symbol BRDF_SLOT_A"), "{err}");
    }
}
