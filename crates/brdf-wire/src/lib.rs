//! Wire formats shared by the firmware and the host, `no_std`: the versioned parameter blob
//! ([`blob`]), the query frames over a byte stream ([`frame`]) and the two flash slots a
//! device keeps its parameters in ([`slots`]).
//!
//! ```
//! use brdf_wire::frame::{encode_request, parse_request, FrameReader, Input, Request, MAX_FRAME};
//!
//! let mut wire = [0u8; MAX_FRAME];
//! let req = Request::Eval { material: 0, input: Input::Cosines, x: [1.0, 1.0, 1.0] };
//! let n = encode_request(&req, 7, &mut wire).unwrap();
//! let mut reader: FrameReader<256> = FrameReader::new();
//! let mut frames = 0;
//! for &b in &wire[..n] {
//!     if let Some(Ok(())) = reader.push(b) {
//!         assert_eq!(parse_request(reader.payload()).unwrap(), (7, req));
//!         frames += 1;
//!     }
//! }
//! assert_eq!(frames, 1);
//! ```
#![no_std]
#![deny(missing_docs)]

pub mod blob;
pub mod frame;
pub mod slots;

/// CRC-32 (ISO-HDLC: the zlib and Ethernet polynomial) of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
    CRC.checksum(bytes)
}

/// The README's example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
