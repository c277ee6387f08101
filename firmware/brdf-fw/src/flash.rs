//! The two parameter slots in flash, behind [`Flash`]; [`write_slot`] is the only way a
//! slot is written (erase, blob bytes, length word last, read back).
//!
//! Slot addresses come from the linker symbols `BRDF_SLOT_A` / `BRDF_SLOT_B` of the board's
//! memory map, which `brdf flash` reads from the ELF as well.

use brdf_wire::slots::{SlotId, SLOT_IMAGE_LEN};

extern "C" {
    static BRDF_SLOT_A: u8;
    static BRDF_SLOT_B: u8;
}

/// Start address of a slot.
pub fn slot_address(slot: SlotId) -> usize {
    // Only the addresses of the linker symbols are taken, never their contents.
    match slot {
        SlotId::A => core::ptr::addr_of!(BRDF_SLOT_A) as usize,
        SlotId::B => core::ptr::addr_of!(BRDF_SLOT_B) as usize,
    }
}

/// The memory-mapped image of a slot.
pub(crate) fn mapped_slot(slot: SlotId) -> &'static [u8] {
    // SAFETY: the slot regions lie in the board's flash (or QEMU code memory) outside every
    // section of the program, are readable for SLOT_IMAGE_LEN bytes, and are only changed
    // through `Flash::erase` / `Flash::program`, which take `&mut self` while every `slot()`
    // borrow takes `&self`.
    unsafe { core::slice::from_raw_parts(slot_address(slot) as *const u8, SLOT_IMAGE_LEN) }
}

/// Why a flash operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum FlashError {
    /// The controller reported an error (status register bits).
    Controller(u32),
    /// The read-back differs from what was written.
    Verify,
    /// Offset or length outside the slot image, or not word-aligned where required.
    Range,
    /// The change could not be made persistent (QEMU: the host file could not be written,
    /// or is not used because it was found damaged at boot).
    Persist,
}

/// Checks a program request: word-aligned offset and length inside the slot image.
pub(crate) fn check_program(offset: usize, len: usize) -> Result<(), FlashError> {
    if !offset.is_multiple_of(4) || !len.is_multiple_of(4) || offset + len > SLOT_IMAGE_LEN {
        return Err(FlashError::Range);
    }
    Ok(())
}

/// Two slots of flash.
pub trait Flash {
    /// The slot's image, [`SLOT_IMAGE_LEN`] bytes.
    fn slot(&self, slot: SlotId) -> &[u8];
    /// Erases the slot (every byte 0xFF).
    fn erase(&mut self, slot: SlotId) -> Result<(), FlashError>;
    /// Programs `bytes` at `offset` into an erased slot (offset and length multiples of 4).
    fn program(&mut self, slot: SlotId, offset: usize, bytes: &[u8]) -> Result<(), FlashError>;
}

/// Writes a slot image (from `brdf_wire::slots::plan_commit`) to `slot`: erase, the blob
/// bytes, then the length word, then a full read-back. Interrupted anywhere, the slot reads
/// as empty or invalid and the other slot is untouched.
pub fn write_slot<F: Flash>(flash: &mut F, slot: SlotId, image: &[u8]) -> Result<(), FlashError> {
    if image.len() < 4 || image.len() > SLOT_IMAGE_LEN {
        return Err(FlashError::Range);
    }
    flash.erase(slot)?;
    flash.program(slot, 4, &image[4..])?;
    flash.program(slot, 0, &image[..4])?;
    if flash.slot(slot).get(..image.len()) != Some(image) {
        return Err(FlashError::Verify);
    }
    Ok(())
}

#[cfg(feature = "qemu")]
pub use qemu::QemuFlash;

#[cfg(feature = "qemu")]
mod qemu {
    use super::{mapped_slot, slot_address, Flash, FlashError};
    use brdf_wire::slots::{SlotId, SLOT_IMAGE_LEN};
    use cortex_m_semihosting::{nr, syscall};

    /// Host file holding both slot images (A then B), in QEMU's working directory.
    const IMAGE_FILE: &[u8] = b"brdf-flash.bin\0";

    /// QEMU's code memory is RAM: the slots are written in place like flash (erase to 0xFF,
    /// programming only clears bits) and every change is mirrored to [`IMAGE_FILE`] on the
    /// host over semihosting; at boot the file is read back, so the slots survive a restart
    /// exactly as flash would. A file that is neither empty nor exactly both slot images long
    /// is reported and left as it is, and a file that cannot be written makes every write
    /// fail with [`FlashError::Persist`]: COMMIT then answers `FlashFailed` rather than
    /// claim parameters that a restart would lose.
    pub struct QemuFlash {
        handle: Option<usize>,
    }

    impl defmt::Format for QemuFlash {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "QemuFlash(persistent: {=bool})", self.handle.is_some())
        }
    }

    fn file_offset(slot: SlotId) -> usize {
        match slot {
            SlotId::A => 0,
            SlotId::B => SLOT_IMAGE_LEN,
        }
    }

    /// Bytes of the host file: slot A's image, then slot B's.
    const FILE_LEN: usize = 2 * SLOT_IMAGE_LEN;

    impl QemuFlash {
        /// Opens (or creates, erased) the host file and loads both slots from it.
        pub fn open() -> QemuFlash {
            let name_len = IMAGE_FILE.len() - 1;
            let name = "brdf-flash.bin";
            // SAFETY: semihosting calls with a NUL-terminated name and its length.
            let mut h = unsafe { syscall!(OPEN, IMAGE_FILE.as_ptr(), nr::open::RW_BINARY, name_len) };
            if h == usize::MAX {
                // SAFETY: as above.
                h = unsafe { syscall!(OPEN, IMAGE_FILE.as_ptr(), nr::open::RW_TRUNC_BINARY, name_len) };
            }
            let mut flash = QemuFlash {
                handle: (h != usize::MAX).then_some(h),
            };
            for slot in [SlotId::A, SlotId::B] {
                flash.fill_erased(slot);
            }
            let Some(h) = flash.handle else {
                defmt::warn!(
                    "flash: cannot open {=str}: slots read as erased, COMMIT refused",
                    name
                );
                return flash;
            };
            // SAFETY: FLEN of the handle just opened.
            let len = unsafe { syscall!(FLEN, h) };
            if len == 0 {
                // A new file: both slots erased.
                let written = flash.mirror(SlotId::A, 0, SLOT_IMAGE_LEN).is_ok()
                    && flash.mirror(SlotId::B, 0, SLOT_IMAGE_LEN).is_ok();
                if !written {
                    defmt::warn!("flash: cannot write {=str}: COMMIT refused", name);
                    flash.handle = None;
                }
            } else if len != FILE_LEN {
                defmt::warn!(
                    "flash: {=str} is {=usize} bytes, not {=usize}: left as it is, slots read as erased, COMMIT refused",
                    name,
                    len,
                    FILE_LEN
                );
                flash.handle = None;
            } else if !(flash.load(SlotId::A) && flash.load(SlotId::B)) {
                defmt::warn!(
                    "flash: cannot read {=str}: slots read as erased, COMMIT refused",
                    name
                );
                for slot in [SlotId::A, SlotId::B] {
                    flash.fill_erased(slot);
                }
                flash.handle = None;
            }
            flash
        }

        fn base(slot: SlotId) -> *mut u8 {
            slot_address(slot) as *mut u8
        }

        /// Reads the slot's image from the host file into code memory; false if short.
        fn load(&mut self, slot: SlotId) -> bool {
            let Some(h) = self.handle else { return false };
            // SAFETY: seek and read into the slot region, SLOT_IMAGE_LEN writable bytes of
            // QEMU code memory outside the program.
            let not_read = unsafe {
                if syscall!(SEEK, h, file_offset(slot)) != 0 {
                    return false;
                }
                syscall!(READ, h, Self::base(slot), SLOT_IMAGE_LEN)
            };
            not_read == 0
        }

        fn fill_erased(&mut self, slot: SlotId) {
            for i in 0..SLOT_IMAGE_LEN {
                // SAFETY: inside the slot region (see `load`).
                unsafe { core::ptr::write_volatile(Self::base(slot).add(i), 0xFF) };
            }
        }

        /// Copies `len` bytes at `offset` of the slot to the host file.
        fn mirror(&mut self, slot: SlotId, offset: usize, len: usize) -> Result<(), FlashError> {
            let h = self.handle.ok_or(FlashError::Persist)?;
            // SAFETY: seek and write from inside the slot region.
            let not_written = unsafe {
                if syscall!(SEEK, h, file_offset(slot) + offset) != 0 {
                    return Err(FlashError::Persist);
                }
                syscall!(WRITE, h, Self::base(slot).add(offset), len)
            };
            if not_written == 0 {
                Ok(())
            } else {
                Err(FlashError::Persist)
            }
        }
    }

    impl Flash for QemuFlash {
        fn slot(&self, slot: SlotId) -> &[u8] {
            mapped_slot(slot)
        }

        fn erase(&mut self, slot: SlotId) -> Result<(), FlashError> {
            if self.handle.is_none() {
                return Err(FlashError::Persist);
            }
            self.fill_erased(slot);
            self.mirror(slot, 0, SLOT_IMAGE_LEN)
        }

        fn program(&mut self, slot: SlotId, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
            super::check_program(offset, bytes.len())?;
            if self.handle.is_none() {
                return Err(FlashError::Persist);
            }
            for (i, &b) in bytes.iter().enumerate() {
                // SAFETY: inside the slot region (checked above). Programming flash can only
                // clear bits.
                unsafe {
                    let p = Self::base(slot).add(offset + i);
                    core::ptr::write_volatile(p, core::ptr::read_volatile(p) & b);
                }
            }
            self.mirror(slot, offset, bytes.len())
        }
    }
}
