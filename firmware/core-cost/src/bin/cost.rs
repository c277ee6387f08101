//! Instruction cost of each evaluation path on the target's core, measured under QEMU by
//! `bench/firmware_cost.sh` (and re-counted on the Cortex-M4F by `tests/tests/firmware_cost.rs`).
//!
//! Each path runs [`N`] evaluations between two marker functions. Two independent counts:
//! - under `-icount shift=0` one instruction is one nanosecond of virtual time and SysTick
//!   counts them (`core_cost::ticks`); this binary reads it and prints instructions per
//!   evaluation over semihosting;
//! - under `-singlestep -d exec` the script counts the logged instructions between markers.
//!
//! The two agree to within the SysTick resolution (40 to 63 instructions per run of N).
#![no_std]
#![no_main]

use brdf_core::fitted::{encode_fitted, Corrected, FittedShape, FittedTable};
use brdf_core::table::{fill_six_table, table_len, SixTable};
use brdf_core::{Brdf, FiveParam, Ggx, Lambert, Minnaert, Model, SixParam, SixParamCos2};
use core::hint::black_box;
use core_cost::exit;
use core_cost::ticks::Ticks;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;

/// Evaluations per measured run.
const N: usize = 100;

#[inline(never)]
#[no_mangle]
extern "C" fn cost_marker_start(id: u32) -> u32 {
    black_box(id + 1)
}

#[inline(never)]
#[no_mangle]
extern "C" fn cost_marker_end(id: u32) -> u32 {
    black_box(id + 2)
}

/// Runs `f` N times between the markers and prints its instructions per call.
fn measure(id: u32, name: &str, ticks: &Ticks, mut f: impl FnMut(f32) -> f32) {
    let mut acc = 0.0f32;
    let t0 = ticks.now();
    cost_marker_start(id);
    for k in 0..N {
        acc += f(black_box(k as f32 * 0.002));
    }
    cost_marker_end(id);
    let t1 = ticks.now();
    black_box(acc);
    hprintln!(
        "path {}: {} : {} instructions",
        id,
        name,
        Ticks::instructions(t1 - t0) / N as u64
    );
}

#[inline(always)]
fn angles<M: Brdf<f32>>(m: &M, x: f32) -> f32 {
    m.eval_angles(black_box(0.2 + x), black_box(0.7 - x), black_box(1.0 + x))
}

#[inline(always)]
fn vectors<M: Brdf<f32>>(m: &M, x: f32) -> f32 {
    // Unit vectors to within an ulp or two: (2t, 1 - t^2) / (1 + t^2) and (-0.48, 0.36, 0.8).
    let t = 0.3 + x;
    let n = 1.0 / (1.0 + t * t);
    m.eval_vectors(
        [
            black_box(2.0 * t * n),
            black_box(0.0),
            black_box((1.0 - t * t) * n),
        ],
        [black_box(-0.48), black_box(0.36), black_box(0.8)],
    )
}

#[inline(always)]
fn cosines<M: Brdf<f32>>(m: &M, x: f32) -> f32 {
    m.eval_cosines(black_box(0.9 - x), black_box(0.7 + x), black_box(-0.3 + x))
}

/// A path that does no work: returns its first input.
struct Null;

impl Brdf<f32> for Null {
    fn eval(&self, g: &brdf_core::Geometry<f32>) -> f32 {
        g.cos_theta_i()
    }
    #[inline(always)]
    fn eval_cosines(&self, cos_theta_i: f32, _: f32, _: f32) -> f32 {
        cos_theta_i
    }
    #[inline(always)]
    fn eval_vectors(&self, wi: [f32; 3], _: [f32; 3]) -> f32 {
        wi[2]
    }
}

/// The geometry alone: every quantity a model reads from it, summed.
struct GeometryOnly;

impl Brdf<f32> for GeometryOnly {
    #[inline(always)]
    fn eval(&self, g: &brdf_core::Geometry<f32>) -> f32 {
        g.cos_theta_i()
            + g.cos_theta_r()
            + g.cos_gamma()
            + g.one_minus_cos_gamma()
            + g.cos_alpha()
            + g.one_minus_cos_alpha()
    }
}

#[entry]
fn main() -> ! {
    let ticks = Ticks::start();
    let p = black_box(brdf_core::table1_f32(0));
    let (Ok(six), Ok(six_cos2), Ok(five), Ok(minnaert), Ok(lambert), Ok(ggx)) = (
        SixParam::from_params(&p),
        SixParamCos2::from_params(&p),
        FiveParam::from_params(&p[..5]),
        Minnaert::from_params(&[0.3, 0.8]),
        Lambert::from_params(&[0.3]),
        Ggx::from_params(&[0.9, 0.1, 0.04, 0.2]),
    ) else {
        exit(false)
    };
    measure(0, "loop alone (inputs, call, sum)", &ticks, |x| cosines(&Null, x));
    measure(1, "six exact from angles", &ticks, |x| angles(&six, x));
    measure(2, "six exact from cosines", &ticks, |x| cosines(&six, x));
    let mut bytes = [0u8; table_len(1024)];
    let six_p = six.params();
    for (id, nodes) in [(3, 64), (4, 256), (5, 1024)] {
        let buf = &mut bytes[..table_len(nodes)];
        if fill_six_table(&six_p, nodes, buf).is_err() {
            exit(false);
        }
        let Ok(t) = SixTable::new(six_p, buf) else {
            exit(false)
        };
        let name = match nodes {
            64 => "six table 64 from cosines",
            256 => "six table 256 from cosines",
            _ => "six table 1024 from cosines",
        };
        measure(id, name, &ticks, |x| cosines(&t, x));
    }
    measure(6, "five exact from cosines", &ticks, |x| cosines(&five, x));
    measure(7, "minnaert exact from cosines", &ticks, |x| {
        cosines(&minnaert, x)
    });
    measure(8, "lambert exact from cosines", &ticks, |x| cosines(&lambert, x));
    // As the firmware serves EVAL: constants computed at LOAD, rebound to the blob per query.
    let buf = &mut bytes[..table_len(256)];
    if fill_six_table(&six_p, 256, buf).is_err() {
        exit(false);
    }
    let buf = &bytes[..table_len(256)];
    let Ok(t) = SixTable::new(six_p, buf) else {
        exit(false)
    };
    let consts = t.consts();
    measure(
        9,
        "six table 256 from cosines, rebound per query",
        &ticks,
        |x| match SixTable::from_parts(black_box(consts), buf) {
            Some(t) => cosines(&t, x),
            None => f32::NAN,
        },
    );
    measure(
        10,
        "six table 256 from angles, rebound per query",
        &ticks,
        |x| match SixTable::from_parts(black_box(consts), buf) {
            Some(t) => angles(&t, x),
            None => f32::NAN,
        },
    );
    measure(11, "six-cos2 exact from cosines", &ticks, |x| {
        cosines(&six_cos2, x)
    });
    measure(12, "five exact from angles", &ticks, |x| angles(&five, x));
    measure(13, "minnaert exact from angles", &ticks, |x| angles(&minnaert, x));
    measure(14, "lambert exact from angles", &ticks, |x| angles(&lambert, x));
    measure(15, "six-cos2 exact from angles", &ticks, |x| angles(&six_cos2, x));
    measure(16, "loop alone, vectors (inputs, call, sum)", &ticks, |x| {
        vectors(&Null, x)
    });
    measure(17, "six exact from vectors", &ticks, |x| vectors(&six, x));
    measure(18, "six table 256 from vectors", &ticks, |x| vectors(&t, x));
    measure(19, "geometry alone from cosines", &ticks, |x| {
        cosines(&GeometryOnly, x)
    });
    // A 20 x 19 x 5 fitted table over the microfacet base `brdf select` uses, as the firmware serves EVAL: its header read
    // once, rebound to the blob bytes per query.
    const SHAPE: FittedShape = FittedShape {
        theta_h: 20,
        theta_d: 19,
        phi_d: 5,
    };
    let mut values = [0.0f64; SHAPE.cells()];
    let mut covered = [false; SHAPE.cells()];
    for (k, (v, c)) in values.iter_mut().zip(covered.iter_mut()).enumerate() {
        *v = ((k % 23) as f64 - 11.0) / 7.0;
        *c = k % 3 != 0;
    }
    let mut fitted = [0u8; SHAPE.encoded_len()];
    if encode_fitted(SHAPE, &values, &covered, &mut fitted).is_err() {
        exit(false);
    }
    let fitted = &fitted[..];
    let Ok(consts) = FittedTable::new(fitted).map(|t| t.consts()) else {
        exit(false)
    };
    measure(
        20,
        "ggx + fitted table from cosines, rebound per query",
        &ticks,
        |x| match FittedTable::from_parts(black_box(consts), fitted) {
            Some(table) => cosines(&Corrected { base: ggx, table }, x),
            None => f32::NAN,
        },
    );
    measure(21, "ggx exact from cosines", &ticks, |x| cosines(&ggx, x));
    measure(22, "ggx exact from angles", &ticks, |x| angles(&ggx, x));
    banded(&ticks);
    exit(true)
}

/// A banded material of 31 six-parameter bands (a spectral fit of 400-700 nm at 10 nm) as
/// the firmware serves EVAL_AT: once per request its two bands around the wavelength are
/// found and built from the blob's bytes (path 23), then every direction evaluates both and
/// blends them (path 24).
fn banded(ticks: &Ticks) {
    use brdf_core::bands::{blend, Located};
    use brdf_wire::blob::{table1_blob, Blob, Material};
    let khaki = table1_blob().materials[0];
    let mut pairs = [(0.0f64, khaki); 31];
    for (k, p) in pairs.iter_mut().enumerate() {
        let mut q = brdf_core::TABLE1[0].1;
        q[4] = 0.1 + 0.02 * k as f64;
        let Ok(m) = Material::from_params(brdf_core::ModelKind::Six, &q) else {
            exit(false)
        };
        *p = (0.4 + 0.01 * k as f64, m);
    }
    let mut extra = [0u8; 1024];
    let Ok((material, len)) = Material::banded(&pairs, &mut extra) else {
        exit(false)
    };
    let mut blob = table1_blob();
    blob.materials[0] = material;
    let mut bytes = [0u8; 2048];
    let Ok(n) = blob.encode_with_tables(&[Some(&extra[..len])], &mut bytes) else {
        exit(false)
    };
    let bytes = &bytes[..n];
    let Ok(decoded) = Blob::decode(bytes) else {
        exit(false)
    };
    let m = decoded.materials[0];
    let resolve = |um: f32| match m.locate(bytes, um) {
        Ok(Located::Between { lower, weight }) => {
            match (m.band_model(bytes, lower), m.band_model(bytes, lower + 1)) {
                (Some(a), Some(b)) => Some((a, b, weight)),
                _ => None,
            }
        }
        _ => None,
    };
    measure(
        23,
        "six banded (31 bands), two bands found and built at a wavelength",
        ticks,
        |x| resolve(black_box(0.555)).map_or(f32::NAN, |(_, _, w)| w + x),
    );
    let Some((a, b, w)) = resolve(0.555) else {
        exit(false)
    };
    measure(24, "six banded, two bands blended from cosines", ticks, |x| {
        let g =
            brdf_core::Geometry::from_cosines(black_box(0.9 - x), black_box(0.7 + x), black_box(-0.3 + x));
        blend(a.eval(&g), b.eval(&g), black_box(w))
    });
}
