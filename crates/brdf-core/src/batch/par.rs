//! The batch path spread over all cores (rayon; feature `rayon`): `brdf bench eval` and the
//! Python package's `brdf.eval`. Each direction's value is the one
//! [`Batch`] gives on one thread, bit for bit.

extern crate std;

use super::{Batch, BatchError};
use crate::Float;
use rayon::prelude::*;

/// Directions per parallel task: large enough that scheduling costs nothing measurable
/// (about 0.1 ms of work), small enough to balance two to a few dozen cores.
pub const PAR_CHUNK: usize = 8192;

/// The inputs of one batch call.
#[derive(Clone, Copy, Debug)]
pub enum Inputs<'a, T> {
    /// `theta_i`, `theta_r`, `phi` (radians).
    Angles([&'a [T]; 3]),
    /// `cos theta_i`, `cos theta_r`, `cos phi`.
    Cosines([&'a [T]; 3]),
    /// `wi` and `wr` by component.
    Vectors([&'a [T]; 3], [&'a [T]; 3]),
}

impl<T> Inputs<'_, T> {
    /// Length of every input slice.
    fn lengths(&self) -> [usize; 6] {
        match self {
            Inputs::Angles(a) | Inputs::Cosines(a) => [
                a[0].len(),
                a[1].len(),
                a[2].len(),
                a[0].len(),
                a[0].len(),
                a[0].len(),
            ],
            Inputs::Vectors(a, b) => [
                a[0].len(),
                a[1].len(),
                a[2].len(),
                b[0].len(),
                b[1].len(),
                b[2].len(),
            ],
        }
    }
}

fn sub<T>(s: [&[T]; 3], r: std::ops::Range<usize>) -> [&[T]; 3] {
    [&s[0][r.clone()], &s[1][r.clone()], &s[2][r]]
}

/// One batch call on `out.len()` directions starting at `start` of `inputs`.
fn call<T: Float>(
    b: &Batch<T>,
    inputs: Inputs<'_, T>,
    start: usize,
    out: &mut [T],
) -> Result<(), BatchError> {
    let r = start..start + out.len();
    let shifted = |e: BatchError| match e {
        BatchError::Domain { index, error } => BatchError::Domain {
            index: index + start,
            error,
        },
        other => other,
    };
    match inputs {
        Inputs::Angles(a) => {
            let a = sub(a, r);
            b.angles(a[0], a[1], a[2], out)
        }
        Inputs::Cosines(c) => {
            let c = sub(c, r);
            b.cosines(c[0], c[1], c[2], out)
        }
        Inputs::Vectors(wi, wr) => b.vectors(sub(wi, r.clone()), sub(wr, r), out),
    }
    .map_err(shifted)
}

/// `Batch::angles` / `cosines` / `vectors` over `inputs` into `out`, on all cores when
/// `parallel`, with the same contract as the core: the first invalid direction's index, its
/// value and every later one NaN.
pub fn eval<T: Float + Send + Sync>(
    b: &Batch<T>,
    inputs: Inputs<'_, T>,
    out: &mut [T],
    parallel: bool,
) -> Result<(), BatchError> {
    if let Some(&len) = inputs.lengths().iter().find(|&&l| l != out.len()) {
        return Err(BatchError::Length {
            what: "input",
            len,
            expected: out.len(),
        });
    }
    if !parallel {
        return call(b, inputs, 0, out);
    }
    let first_error = out
        .par_chunks_mut(PAR_CHUNK)
        .enumerate()
        .filter_map(|(k, o)| call(b, inputs, k * PAR_CHUNK, o).err())
        .min_by_key(|e| match e {
            BatchError::Domain { index, .. } => *index,
            _ => 0,
        });
    match first_error {
        None => Ok(()),
        Some(e) => {
            if let BatchError::Domain { index, .. } = e {
                for o in &mut out[index..] {
                    *o = T::from_f64(f64::NAN);
                }
            }
            Err(e)
        }
    }
}
