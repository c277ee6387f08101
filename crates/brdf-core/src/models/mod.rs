//! The model family, one file per model, each generic over `f32` and `f64`.

mod five;
mod lambert;
mod minnaert;
mod six;
mod six_cos2;

pub use five::{FiveParam, FiveParams};
pub use lambert::{Lambert, LambertParams};
pub use minnaert::{Minnaert, MinnaertParams};
pub use six::{SixParam, SixParams};
pub use six_cos2::SixParamCos2;

use crate::float::{product_error, split, Float};
use crate::geometry::Geometry;

/// Facet term of eq. 1 and eq. 3, `kr^2 cos(alpha) / (1 + (kr^2 - 1) cos(alpha))`, written as
/// `kr^2 cos(alpha) / (kr^2 cos(alpha) + (1 - cos(alpha)))`: the textbook denominator cancels
/// in f32 for `kr < 1` near the mirror direction, this one has no subtraction. In `(0, 1]`.
#[inline]
pub(crate) fn facet<T: Float>(kr2: T, g: &Geometry<T>) -> T {
    let x = kr2 * g.cos_alpha();
    x / (x + g.one_minus_cos_alpha())
}

/// Local-incidence lobe of eq. 1 and eq. 3, `exp(-|b| (1 - cos(gamma))^a)`, in `(0, 1]`;
/// exactly 1 at the retro direction (`0^a = 0` for `a > 0`).
///
/// The relative error of `exp(-E)` is the absolute error of `E = |b| x^a`, i.e. `E` times its
/// relative error; `E` reaches ~14 where `f_r` is still a millionth of its peak. The product
/// `|b| * x^a` is therefore carried as an exact sum `E_hi + E_lo` (Dekker's TwoProduct with
/// `|b|` split once per material) and `exp(-E_hi - E_lo) = exp(-E_hi) (1 - E_lo)`: in f32
/// this removes one rounding of `E` and the rounding of `exp`'s argument (about 20 flops).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lobe<T> {
    abs_b: T,
    abs_b_hi: T,
    abs_b_lo: T,
    a: T,
}

impl<T: Float> Lobe<T> {
    pub(crate) fn new(b: T, a: T) -> Self {
        let abs_b = b.abs();
        let (abs_b_hi, abs_b_lo) = split(abs_b);
        Lobe {
            abs_b,
            abs_b_hi,
            abs_b_lo,
            a,
        }
    }

    #[inline]
    pub(crate) fn eval(&self, g: &Geometry<T>) -> T {
        let p = g.one_minus_cos_gamma().powf(self.a);
        let e_hi = self.abs_b * p;
        let e_lo = product_error(self.abs_b_hi, self.abs_b_lo, p, e_hi);
        (-e_hi).exp() * (T::ONE - e_lo)
    }
}
