//! Two flash slots (A and B) holding parameter blobs, so that no interrupted write can leave
//! a device without valid parameters.
//!
//! A slot image is a little-endian `u32` length followed by that many blob bytes; an erased
//! slot reads `0xFFFF_FFFF` there. The device boots from the valid slot with the newer
//! sequence number ([`is_newer`]), falls back to the other, and then to its built-in default.
//! A new blob is always written to the slot that is *not* active ([`commit_target`]), blob
//! bytes first and the length word last, then read back and verified; only a complete,
//! valid image with a newer sequence number than the active one ever wins the next boot. An
//! interruption at any point therefore leaves the previously active slot as it was.
//!
//! Sequence numbers compare in serial-number arithmetic (RFC 1982 for 32 bits), so that no
//! number locks the slots: `s + 1` (mod 2^32) is always newer than `s`, and 0 follows
//! 0xFFFF_FFFF. With two slots only the newest and the one before it are ever compared.
//!
//! The firmware and `brdf flash` share this logic; they differ only in how bytes reach flash.

use crate::blob::{Blob, BlobError, MAX_BLOB_LEN};

/// Bytes of a slot image: the length word and the largest blob.
pub const SLOT_IMAGE_LEN: usize = 4 + MAX_BLOB_LEN;

/// The two slots (with the `defmt` feature, logged as `A` and `B`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlotId {
    /// Slot A.
    A,
    /// Slot B.
    B,
}

impl SlotId {
    /// `"A"` or `"B"`.
    pub const fn name(self) -> &'static str {
        match self {
            SlotId::A => "A",
            SlotId::B => "B",
        }
    }

    /// The other slot.
    pub const fn other(self) -> SlotId {
        match self {
            SlotId::A => SlotId::B,
            SlotId::B => SlotId::A,
        }
    }
}

/// What a slot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotState {
    /// Erased (length word `0xFFFF_FFFF`).
    Empty,
    /// A length beyond [`MAX_BLOB_LEN`] (a torn or foreign write).
    BadLength(u32),
    /// A length in range but a blob that does not decode.
    Invalid(BlobError),
    /// A valid blob.
    Valid {
        /// Its sequence number.
        sequence: u32,
        /// CRC-32 of the blob without its own CRC (what INFO reports).
        crc: u32,
        /// Blob length in bytes.
        len: u32,
    },
}

impl SlotState {
    /// The sequence number of a valid slot.
    pub fn sequence(&self) -> Option<u32> {
        match self {
            SlotState::Valid { sequence, .. } => Some(*sequence),
            _ => None,
        }
    }
}

/// One line for the host (`brdf flash`): `empty`, `invalid (length 5000)`,
/// `invalid (blob CRC mismatch)` or `valid, sequence 6, 76 bytes, CRC 0x8bc7d10b`. The
/// firmware's boot log prints the same facts in its own form (the `defmt` feature).
impl core::fmt::Display for SlotState {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SlotState::Empty => write!(f, "empty"),
            SlotState::BadLength(n) => write!(f, "invalid (length {n})"),
            SlotState::Invalid(e) => write!(f, "invalid ({e})"),
            SlotState::Valid { sequence, crc, len } => {
                write!(f, "valid, sequence {sequence}, {len} bytes, CRC {crc:#010x}")
            }
        }
    }
}

/// What the firmware's boot log prints after `boot: slot A `: `empty`, `invalid: length 5000`,
/// `invalid: CRC` (the blob error's short name) or
/// `valid: sequence 6, 76 bytes, CRC 0x8bc7d10b` (the golden boot logs pin this text).
#[cfg(feature = "defmt")]
impl defmt::Format for SlotState {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            SlotState::Empty => defmt::write!(f, "empty"),
            SlotState::BadLength(n) => defmt::write!(f, "invalid: length {=u32}", n),
            SlotState::Invalid(e) => defmt::write!(f, "invalid: {}", e),
            SlotState::Valid { sequence, crc, len } => defmt::write!(
                f,
                "valid: sequence {=u32}, {=u32} bytes, CRC {=u32:#010x}",
                sequence,
                len,
                crc
            ),
        }
    }
}

/// Reads a slot image (at least the length word; more bytes than the image are ignored).
/// Returns its state and, when valid, the blob bytes inside it with the blob they decode to
/// (so that a caller never decodes them again).
pub fn read_slot(image: &[u8]) -> (SlotState, Option<(&[u8], Blob)>) {
    let Some(&[l0, l1, l2, l3]) = image.get(..4) else {
        return (SlotState::BadLength(0), None);
    };
    let len = u32::from_le_bytes([l0, l1, l2, l3]);
    if len == u32::MAX {
        return (SlotState::Empty, None);
    }
    let Some(bytes) = usize::try_from(len)
        .ok()
        .filter(|&n| n <= MAX_BLOB_LEN)
        .and_then(|n| image.get(4..4 + n))
    else {
        return (SlotState::BadLength(len), None);
    };
    match Blob::decode(bytes) {
        Ok(blob) => (
            SlotState::Valid {
                sequence: blob.sequence,
                crc: crate::blob::blob_crc(bytes),
                len,
            },
            Some((bytes, blob)),
        ),
        Err(e) => (SlotState::Invalid(e), None),
    }
}

/// Whether sequence number `candidate` is newer than `current`: their difference
/// `candidate - current` (mod 2^32) lies in `1..2^31`. One rule for the firmware's boot and
/// COMMIT and for `brdf flash`. Numbers exactly 2^31 apart are neither newer nor older:
/// such a blob is refused as stale and, between two such slots, A is used.
pub const fn is_newer(candidate: u32, current: u32) -> bool {
    let d = candidate.wrapping_sub(current);
    d != 0 && d < 1 << 31
}

/// The slot to boot from: the valid one with the newer sequence number ([`is_newer`]; A when
/// neither is newer), or `None` for the built-in default.
pub fn select(a: &SlotState, b: &SlotState) -> Option<SlotId> {
    match (a.sequence(), b.sequence()) {
        (Some(sa), Some(sb)) => Some(if is_newer(sb, sa) { SlotId::B } else { SlotId::A }),
        (Some(_), None) => Some(SlotId::A),
        (None, Some(_)) => Some(SlotId::B),
        (None, None) => None,
    }
}

/// The slot a new blob goes to: never the active one.
pub fn commit_target(active: Option<SlotId>) -> SlotId {
    match active {
        Some(s) => s.other(),
        None => SlotId::A,
    }
}

/// Why a blob may not be committed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CommitError {
    /// The blob does not decode.
    Blob(BlobError),
    /// Its sequence number is not newer than the newest valid slot's ([`is_newer`]).
    Stale {
        /// The blob's sequence number.
        sequence: u32,
        /// The newest valid slot's sequence number.
        active: u32,
    },
}

impl core::fmt::Display for CommitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CommitError::Blob(e) => write!(f, "{e}"),
            CommitError::Stale { sequence, active } => write!(
                f,
                "sequence {sequence} is not newer than the active {active} (serial-number order: use {}): \
                 after a restart the older blob would win",
                active.wrapping_add(1)
            ),
        }
    }
}

/// Both slots as read: their states, the decoded contents of the valid ones, and the one to
/// boot from. The one reading of the slot pair, for the firmware's boot and COMMIT and for
/// `brdf flash`.
#[derive(Clone, Debug, PartialEq)]
pub struct SlotPair<'a> {
    /// What slot A holds.
    pub a: SlotState,
    /// What slot B holds.
    pub b: SlotState,
    /// The slot to boot from ([`select`]): the valid one with the newer sequence number.
    pub newest: Option<SlotId>,
    contents: [Option<(&'a [u8], Blob)>; 2],
}

impl<'a> SlotPair<'a> {
    /// Reads the images of slot A and slot B ([`read_slot`]) and selects the newest valid one.
    pub fn read(image_a: &'a [u8], image_b: &'a [u8]) -> SlotPair<'a> {
        let (a, ca) = read_slot(image_a);
        let (b, cb) = read_slot(image_b);
        let newest = select(&a, &b);
        SlotPair {
            a,
            b,
            newest,
            contents: [ca, cb],
        }
    }

    /// The state of slot `id`.
    pub fn state(&self, id: SlotId) -> &SlotState {
        match id {
            SlotId::A => &self.a,
            SlotId::B => &self.b,
        }
    }

    /// The newest valid slot's sequence number (`None`: no valid slot).
    pub fn newest_sequence(&self) -> Option<u32> {
        self.newest.and_then(|id| self.state(id).sequence())
    }

    /// The slot a new blob goes to ([`commit_target`]): never the newest valid one.
    pub fn target(&self) -> SlotId {
        commit_target(self.newest)
    }

    /// The slot to boot from with its blob bytes and the blob they decode to, or `None` for
    /// the built-in default.
    pub fn into_active(self) -> Option<(SlotId, &'a [u8], Blob)> {
        let id = self.newest?;
        let [a, b] = self.contents;
        let (bytes, blob) = match id {
            SlotId::A => a,
            SlotId::B => b,
        }?;
        Some((id, bytes, blob))
    }

    /// Plans committing `blob` over these slots: checks it ([`slot_image`] against
    /// [`SlotPair::newest_sequence`]), writes its slot image into `out` and names the slot it
    /// goes to ([`SlotPair::target`]).
    pub fn plan(&self, blob: &[u8], out: &mut [u8]) -> Result<CommitPlan, CommitError> {
        let (image_len, blob) = slot_image(blob, self.newest_sequence(), out)?;
        Ok(CommitPlan {
            a: self.a,
            b: self.b,
            target: self.target(),
            image_len,
            blob,
        })
    }
}

/// How a blob is committed over two slots ([`plan_commit`]): what both slots held, the slot
/// to write, and the image to write there (in the caller's buffer).
#[derive(Clone, Debug, PartialEq)]
pub struct CommitPlan {
    /// What slot A held.
    pub a: SlotState,
    /// What slot B held.
    pub b: SlotState,
    /// The slot to write: never the newest valid one.
    pub target: SlotId,
    /// Bytes of the slot image (length word and blob) at the start of the caller's buffer.
    pub image_len: usize,
    /// The blob, decoded and checked.
    pub blob: Blob,
}

impl CommitPlan {
    /// The new blob's sequence number.
    pub fn sequence(&self) -> u32 {
        self.blob.sequence
    }
}

/// The slot commit plan, for the firmware's COMMIT and for `brdf flash`: reads the images of
/// slot A and slot B, finds the newest valid one, checks that `blob` decodes and has a newer
/// sequence number ([`is_newer`]), writes its slot image into `out` and chooses the slot to
/// write ([`commit_target`]). Program `out[..image_len]` there blob-first, length word last,
/// then read it back.
pub fn plan_commit(
    image_a: &[u8],
    image_b: &[u8],
    blob: &[u8],
    out: &mut [u8],
) -> Result<CommitPlan, CommitError> {
    SlotPair::read(image_a, image_b).plan(blob, out)
}

/// The firmware's log text: `sequence 5 not newer than 5`, or the blob error's short name.
#[cfg(feature = "defmt")]
impl defmt::Format for CommitError {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            CommitError::Blob(e) => defmt::write!(f, "{}", e),
            CommitError::Stale { sequence, active } => {
                defmt::write!(f, "sequence {=u32} not newer than {=u32}", sequence, active)
            }
        }
    }
}

/// Checks that `blob` may be committed over the newest valid slot's sequence number
/// (`None`: no valid slot, any sequence number is accepted) and writes its slot image into
/// `out`: the length word, then the blob. Returns the image length and the decoded blob.
/// Program it blob-first, length word last.
pub fn slot_image(blob: &[u8], newest: Option<u32>, out: &mut [u8]) -> Result<(usize, Blob), CommitError> {
    let b = Blob::decode(blob).map_err(CommitError::Blob)?;
    if let Some(active) = newest {
        if !is_newer(b.sequence, active) {
            return Err(CommitError::Stale {
                sequence: b.sequence,
                active,
            });
        }
    }
    let n = 4 + blob.len();
    if out.len() < n {
        return Err(CommitError::Blob(BlobError::BufferTooSmall));
    }
    out[..4].copy_from_slice(&(blob.len() as u32).to_le_bytes());
    out[4..n].copy_from_slice(blob);
    Ok((n, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blob::table1_blob;

    fn image(sequence: u32) -> [u8; SLOT_IMAGE_LEN] {
        let mut b = table1_blob();
        b.sequence = sequence;
        let mut blob = [0u8; MAX_BLOB_LEN];
        let n = b.encode(&mut blob).unwrap();
        let mut img = [0xFFu8; SLOT_IMAGE_LEN];
        slot_image(&blob[..n], Some(sequence.wrapping_sub(1)), &mut img).unwrap();
        img
    }

    #[test]
    fn newest_valid_slot_wins_and_each_fault_falls_back() {
        let erased = [0xFFu8; SLOT_IMAGE_LEN];
        let (a, b) = (image(5), image(6));
        let st = |img: &[u8]| read_slot(img).0;
        assert_eq!(st(&erased), SlotState::Empty);
        assert_eq!(select(&st(&erased), &st(&erased)), None);
        assert_eq!(select(&st(&a), &st(&erased)), Some(SlotId::A));
        assert_eq!(select(&st(&a), &st(&b)), Some(SlotId::B));
        assert_eq!(select(&st(&b), &st(&a)), Some(SlotId::A));
        assert!(matches!(st(&a), SlotState::Valid { sequence: 5, .. }));
        // A flipped byte in B: CRC fails, A wins.
        let mut bad = b;
        bad[40] ^= 0x10;
        assert_eq!(st(&bad), SlotState::Invalid(BlobError::Crc));
        assert_eq!(select(&st(&a), &st(&bad)), Some(SlotId::A));
        // Torn writes: blob half written and length still erased; length written over a
        // partly erased blob.
        let mut torn = erased;
        torn[4..100].copy_from_slice(&b[4..100]);
        assert_eq!(st(&torn), SlotState::Empty);
        let mut torn2 = b;
        torn2[60..].fill(0xFF);
        assert!(matches!(st(&torn2), SlotState::Invalid(_)));
        let mut long = b;
        long[..4].copy_from_slice(&5000u32.to_le_bytes());
        assert_eq!(st(&long), SlotState::BadLength(5000));
        assert_eq!(read_slot(&b[..3]).0, SlotState::BadLength(0));
        // Targets: never the active slot.
        assert_eq!(commit_target(None), SlotId::A);
        assert_eq!(commit_target(Some(SlotId::A)), SlotId::B);
        assert_eq!(commit_target(Some(SlotId::B)), SlotId::A);
    }

    #[test]
    fn stale_and_invalid_blobs_are_not_committed() {
        let mut b = table1_blob();
        b.sequence = 3;
        let mut blob = [0u8; MAX_BLOB_LEN];
        let n = b.encode(&mut blob).unwrap();
        let mut img = [0u8; SLOT_IMAGE_LEN];
        assert_eq!(
            slot_image(&blob[..n], Some(3), &mut img),
            Err(CommitError::Stale {
                sequence: 3,
                active: 3
            })
        );
        assert_eq!(
            slot_image(&blob[..n - 1], None, &mut img),
            Err(CommitError::Blob(BlobError::Crc))
        );
        assert_eq!(slot_image(&blob[..n], Some(2), &mut img).map(|r| r.0), Ok(n + 4));
        let (bytes, decoded) = read_slot(&img).1.unwrap();
        assert_eq!((bytes, decoded.sequence), (&blob[..n], 3));
    }

    #[test]
    fn no_sequence_number_locks_the_slots() {
        // The successor of every number is newer, across the wrap too.
        for s in [0_u32, 1, 5, 0x7FFF_FFFF, 0x8000_0000, 0xFFFF_FFFE, 0xFFFF_FFFF] {
            let next = s.wrapping_add(1);
            assert!(is_newer(next, s) && !is_newer(s, next), "{s:#x}");
            assert!(!is_newer(s, s));
        }
        assert!(is_newer(0, 0xFFFF_FFFF) && is_newer(3, 0xFFFF_FFF0));
        assert!(!is_newer(0x8000_0000, 0) && !is_newer(0, 0x8000_0000));
        // Committing 0xFFFF_FFFF, then 0, then 1: each over the previous, each selected.
        let mut slots = [[0xFFu8; SLOT_IMAGE_LEN]; 2];
        let mut newest: Option<SlotId> = None;
        for sequence in [0xFFFF_FFFE_u32, 0xFFFF_FFFF, 0, 1, 2] {
            let mut b = table1_blob();
            b.sequence = sequence;
            let mut blob = [0u8; MAX_BLOB_LEN];
            let n = b.encode(&mut blob).unwrap();
            let st = |s: &[u8; SLOT_IMAGE_LEN]| read_slot(s).0;
            let seq = newest.and_then(|id| st(&slots[id as usize]).sequence());
            let target = commit_target(newest);
            let mut img = [0xFFu8; SLOT_IMAGE_LEN];
            slot_image(&blob[..n], seq, &mut img).unwrap();
            slots[target as usize] = img;
            newest = select(&st(&slots[0]), &st(&slots[1]));
            assert_eq!(newest, Some(target), "sequence {sequence:#x}");
            // The one before is stale now.
            assert!(matches!(
                slot_image(&blob[..n], Some(sequence), &mut img),
                Err(CommitError::Stale { .. })
            ));
        }
        // A blob exactly 2^31 ahead is neither newer nor older: refused.
        let mut b = table1_blob();
        b.sequence = 0x8000_0002;
        let mut blob = [0u8; MAX_BLOB_LEN];
        let n = b.encode(&mut blob).unwrap();
        let mut img = [0u8; SLOT_IMAGE_LEN];
        assert!(slot_image(&blob[..n], Some(2), &mut img).is_err());
        assert!(slot_image(&blob[..n], None, &mut img).is_ok());
    }

    fn encoded(sequence: u32) -> ([u8; MAX_BLOB_LEN], usize) {
        let mut b = table1_blob();
        b.sequence = sequence;
        let mut blob = [0u8; MAX_BLOB_LEN];
        let n = b.encode(&mut blob).unwrap();
        (blob, n)
    }

    #[test]
    fn commit_plan_over_both_empty_slots_writes_a() {
        let erased = [0xFFu8; SLOT_IMAGE_LEN];
        let (blob, n) = encoded(7);
        let mut out = [0u8; SLOT_IMAGE_LEN];
        let p = plan_commit(&erased, &erased, &blob[..n], &mut out).unwrap();
        assert_eq!(
            (p.a, p.b, p.target),
            (SlotState::Empty, SlotState::Empty, SlotId::A)
        );
        assert_eq!((p.image_len, p.sequence()), (n + 4, 7));
        // The image in `out` reads back as the blob.
        let (state, contents) = read_slot(&out[..p.image_len]);
        assert!(matches!(state, SlotState::Valid { sequence: 7, .. }));
        assert_eq!(contents.unwrap().0, &blob[..n]);
        assert_eq!(SlotPair::read(&erased, &erased).into_active(), None);
    }

    #[test]
    fn commit_plan_writes_the_slot_that_is_not_the_newest_valid_one() {
        let erased = [0xFFu8; SLOT_IMAGE_LEN];
        let mut out = [0u8; SLOT_IMAGE_LEN];
        let (blob, n) = encoded(9);
        // One valid slot, either one: the other is written.
        let p = plan_commit(&image(5), &erased, &blob[..n], &mut out).unwrap();
        assert_eq!(p.target, SlotId::B);
        assert!(matches!(p.a, SlotState::Valid { sequence: 5, .. }));
        let p = plan_commit(&erased, &image(5), &blob[..n], &mut out).unwrap();
        assert_eq!((p.a, p.target), (SlotState::Empty, SlotId::A));
        // Both valid: the older one is overwritten.
        assert_eq!(
            plan_commit(&image(5), &image(6), &blob[..n], &mut out)
                .unwrap()
                .target,
            SlotId::A
        );
        assert_eq!(
            plan_commit(&image(6), &image(5), &blob[..n], &mut out)
                .unwrap()
                .target,
            SlotId::B
        );
        // The active contents are the newest slot's.
        let (a, b) = (image(5), image(6));
        let (id, bytes, decoded) = SlotPair::read(&a, &b).into_active().unwrap();
        assert_eq!((id, decoded.sequence, bytes.len()), (SlotId::B, 6, n));
    }

    #[test]
    fn commit_plan_across_the_sequence_wrap() {
        let (a, b) = (image(0xFFFF_FFFF), image(0));
        // 0 follows 0xFFFF_FFFF: B is the newest, A is written, and 1 is accepted.
        let pair = SlotPair::read(&a, &b);
        assert_eq!(
            (pair.newest, pair.newest_sequence(), pair.target()),
            (Some(SlotId::B), Some(0), SlotId::A)
        );
        let mut out = [0u8; SLOT_IMAGE_LEN];
        let (blob, n) = encoded(1);
        let p = plan_commit(&a, &b, &blob[..n], &mut out).unwrap();
        assert_eq!((p.target, p.sequence()), (SlotId::A, 1));
        // 0xFFFF_FFFF (older than 0 in serial-number order) is stale.
        let (old, m) = encoded(0xFFFF_FFFF);
        assert_eq!(
            plan_commit(&a, &b, &old[..m], &mut out),
            Err(CommitError::Stale {
                sequence: 0xFFFF_FFFF,
                active: 0
            })
        );
    }

    #[test]
    fn commit_plan_skips_a_torn_slot_and_refuses_bad_blobs() {
        let erased = [0xFFu8; SLOT_IMAGE_LEN];
        let valid = image(4);
        // A torn write: length word over a partly erased blob. It never counts as newest,
        // so it is the slot written next.
        let mut torn = image(8);
        torn[60..].fill(0xFF);
        let mut out = [0u8; SLOT_IMAGE_LEN];
        let (blob, n) = encoded(5);
        let p = plan_commit(&torn, &valid, &blob[..n], &mut out).unwrap();
        assert!(matches!(p.a, SlotState::Invalid(_)));
        assert_eq!(p.target, SlotId::A);
        // A blob that does not decode, one that is not newer, and one too large for `out`.
        assert_eq!(
            plan_commit(&torn, &valid, &blob[..n - 1], &mut out),
            Err(CommitError::Blob(BlobError::Crc))
        );
        let (stale, m) = encoded(4);
        assert!(matches!(
            plan_commit(&torn, &valid, &stale[..m], &mut out),
            Err(CommitError::Stale {
                sequence: 4,
                active: 4
            })
        ));
        assert_eq!(
            plan_commit(&erased, &erased, &blob[..n], &mut out[..n]),
            Err(CommitError::Blob(BlobError::BufferTooSmall))
        );
    }

    #[test]
    fn slot_states_print_one_line_each() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(SlotState::Empty.to_string(), "empty");
        assert_eq!(SlotState::BadLength(5000).to_string(), "invalid (length 5000)");
        assert_eq!(
            SlotState::Invalid(BlobError::Crc).to_string(),
            "invalid (blob CRC mismatch)"
        );
        let valid = SlotState::Valid {
            sequence: 6,
            crc: 0x8bc7_d10b,
            len: 76,
        };
        assert_eq!(valid.to_string(), "valid, sequence 6, 76 bytes, CRC 0x8bc7d10b");
    }

    #[test]
    fn any_bytes_read_without_panic() {
        let mut x = 0x1234_5678u32;
        let mut img = [0u8; 300];
        for _ in 0..2000 {
            for v in img.iter_mut() {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                *v = x as u8;
            }
            img[..4].copy_from_slice(&(x % 400).to_le_bytes());
            assert!(!matches!(read_slot(&img).0, SlotState::Valid { .. }));
        }
    }
}
