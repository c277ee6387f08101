//! Frames and blobs: round trips, resynchronisation, and decoders fuzzed with arbitrary bytes.

use brdf_core::ModelKind;
use brdf_wire::blob::Blob;
use brdf_wire::frame::{
    encode_request, encode_response, parse_request, parse_response, points, samples, ErrorCode, FrameReader,
    Input, Request, Response, MAX_FRAME,
};
use proptest::prelude::*;

type Reader = FrameReader<{ MAX_FRAME }>;

fn frame(req: &Request<'_>, tag: u8) -> Vec<u8> {
    let mut out = vec![0u8; MAX_FRAME];
    let n = encode_request(req, tag, &mut out).unwrap();
    out.truncate(n);
    out
}

/// Feeds bytes; returns every outcome at a delimiter, with the parsed request when good.
fn feed(reader: &mut Reader, bytes: &[u8]) -> Vec<Result<(u8, String), ErrorCode>> {
    let mut out = Vec::new();
    for &b in bytes {
        match reader.push(b) {
            Some(Ok(())) => out.push(parse_request(reader.payload()).map(|(t, r)| (t, format!("{r:?}")))),
            Some(Err(e)) => out.push(Err(e)),
            None => {}
        }
    }
    out
}

fn requests() -> Vec<Vec<u8>> {
    let pts: Vec<u8> = [0.1f32, 0.2, 3.0, 0.5, 0.5, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let smp: Vec<u8> = [0.1f32, 0.2, 3.0, 0.05]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    vec![
        frame(&Request::Info, 1),
        frame(
            &Request::Eval {
                material: 2,
                input: Input::Angles,
                x: [0.1, 0.2, 0.0],
            },
            2,
        ),
        frame(
            &Request::EvalBatch {
                material: 0,
                input: Input::Cosines,
                points: &pts,
            },
            3,
        ),
        frame(&Request::Load(&[1, 2, 3, 0, 0, 5]), 4),
        frame(&Request::Commit(&[9; 40]), 5),
        frame(
            &Request::Fit {
                model: ModelKind::Minnaert,
                budget: 1000,
                samples: &smp,
            },
            6,
        ),
        frame(
            &Request::EvalAt {
                material: 1,
                input: Input::Angles,
                wavelength: 0.555,
                points: &pts,
            },
            7,
        ),
    ]
}

#[test]
fn every_request_and_reply_round_trips() {
    let mut r = Reader::new();
    for (k, f) in requests().iter().enumerate() {
        let got = feed(&mut r, f);
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].as_ref().unwrap().0, k as u8 + 1);
    }
    let pts: Vec<u8> = [0.1f32, 0.2, 3.0, 0.5, 0.5, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let mut out = vec![0u8; MAX_FRAME];
    let n = encode_request(
        &Request::EvalBatch {
            material: 1,
            input: Input::Angles,
            points: &pts,
        },
        9,
        &mut out,
    )
    .unwrap();
    let mut rd = Reader::new();
    for &b in &out[..n] {
        if let Some(Ok(())) = rd.push(b) {
            let (tag, req) = parse_request(rd.payload()).unwrap();
            assert_eq!(tag, 9);
            let Request::EvalBatch { points: p, .. } = req else {
                panic!("{req:?}")
            };
            assert_eq!(points(p).collect::<Vec<_>>(), [[0.1, 0.2, 3.0], [0.5, 0.5, 0.0]]);
        }
    }
    // EVAL_AT carries its wavelength and points; a count that disagrees with the body is
    // malformed.
    let at = Request::EvalAt {
        material: 3,
        input: Input::Cosines,
        wavelength: 1.064,
        points: &pts,
    };
    let f = frame(&at, 11);
    let mut rd = Reader::new();
    for &b in &f {
        if let Some(Ok(())) = rd.push(b) {
            assert_eq!(parse_request(rd.payload()).unwrap(), (11, at));
            let mut bad = rd.payload().to_vec();
            bad[3 + 6] = 3;
            assert_eq!(parse_request(&bad).unwrap_err(), ErrorCode::Malformed);
            assert_eq!(parse_request(&bad[..3 + 7]).unwrap_err(), ErrorCode::Malformed);
        }
    }
    let vals: Vec<u8> = [1.5f32, 2.5].iter().flat_map(|v| v.to_le_bytes()).collect();
    let replies = [
        Response::Info {
            build_id: 0xdead_beef,
            format_version: 1,
            active_crc: 42,
            materials: 3,
        },
        Response::Value(0.25),
        Response::Values(&vals),
        Response::Done(77),
        Response::Fitted {
            model: ModelKind::Six,
            params: [0.25, 21.8, -27.5, 0.67, 0.37, 1.2],
            rms_rel: 0.01,
            evals: 5000,
        },
        Response::Progress {
            done: 4096,
            budget: 100_000,
        },
        Response::Error(ErrorCode::UnknownMaterial),
    ];
    for (k, resp) in replies.iter().enumerate() {
        let mut out = vec![0u8; MAX_FRAME];
        let n = encode_response(resp, k as u8, &mut out).unwrap();
        let mut rd = Reader::new();
        let mut seen = 0;
        for &b in &out[..n] {
            if let Some(Ok(())) = rd.push(b) {
                assert_eq!(parse_response(rd.payload()).unwrap(), (k as u8, *resp));
                seen += 1;
            }
        }
        assert_eq!(seen, 1);
    }
    let smp: Vec<u8> = [0.1f32, 0.2, 3.0, 0.05]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    assert_eq!(samples(&smp).collect::<Vec<_>>(), [[0.1, 0.2, 3.0, 0.05]]);
}

#[test]
fn resynchronises_after_garbage_and_oversize_frames() {
    let mut r = Reader::new();
    // Garbage ending in a delimiter: one bad frame, then the valid one.
    let mut bytes = vec![7u8, 200, 13, 255, 0];
    bytes.extend(frame(&Request::Info, 11));
    let got = feed(&mut r, &bytes);
    assert_eq!(got.len(), 2);
    assert_eq!(got[0], Err(ErrorCode::BadCrc));
    assert_eq!(got[1].as_ref().unwrap().0, 11);
    // A frame longer than the buffer: FrameTooLarge at its delimiter, then normal service.
    let mut small: FrameReader<16> = FrameReader::new();
    let mut out = vec![];
    for &b in [vec![1u8; 40], vec![0], frame(&Request::Info, 12)]
        .concat()
        .iter()
    {
        if let Some(x) = small.push(b) {
            out.push(x.map(|()| parse_request(small.payload()).unwrap().0));
        }
    }
    assert_eq!(out, [Err(ErrorCode::FrameTooLarge), Ok(12)]);
}

#[test]
fn hundred_thousand_bytes_of_noise_and_corruption_between_valid_frames() {
    // Deterministic stream: valid frames, random bytes, truncated and bit-flipped frames.
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let valid = requests();
    let mut stream = Vec::new();
    let mut expected_good = 0;
    while stream.len() < 100_000 {
        let f = &valid[(next() % valid.len() as u64) as usize];
        match next() % 4 {
            0 => {
                stream.extend((0..(next() % 64)).map(|_| next() as u8));
                stream.push(0);
            }
            1 => {
                // Cut before the last data byte (a cut at the delimiter would be the whole frame).
                let cut = (next() as usize) % (f.len() - 1);
                stream.extend(&f[..cut]);
                stream.push(0);
            }
            2 => {
                // Flip one bit of one byte (never creating a 0, which would be a delimiter).
                let mut g = f.clone();
                let i = (next() as usize) % (g.len() - 1);
                let k = next() % 8;
                g[i] = f[i] ^ (1 << k);
                if g[i] == 0 {
                    g[i] = f[i] ^ (1 << ((k + 1) % 8));
                }
                stream.extend(&g);
            }
            _ => {}
        }
        stream.extend(f);
        expected_good += 1;
    }
    let mut r = Reader::new();
    let got = feed(&mut r, &stream);
    let good = got.iter().filter(|x| x.is_ok()).count();
    // Every valid frame decodes; no corrupted frame passes the CRC.
    assert_eq!(good, expected_good, "stream of {} bytes", stream.len());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn decoders_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut r: FrameReader<256> = FrameReader::new();
        for &b in &bytes {
            if let Some(Ok(())) = r.push(b) {
                let _ = parse_request(r.payload());
                let _ = parse_response(r.payload());
            }
        }
        let _ = Blob::decode(&bytes);
        let _ = parse_request(&bytes);
        let _ = parse_response(&bytes);
    }
}

/// Every code's printed name is its variant's name (what `brdf query` and the link's errors
/// print), and every wire byte maps back to it.
#[test]
fn error_codes_print_their_names() {
    let mut n = 0;
    for b in 0..=u8::MAX {
        if let Some(code) = ErrorCode::from_u8(b) {
            assert_eq!(code as u8, b);
            assert_eq!(code.to_string(), format!("{code:?}"));
            n += 1;
        }
    }
    assert_eq!(n, 13);
    assert_eq!(ErrorCode::StaleSequence.to_string(), "StaleSequence");
}
