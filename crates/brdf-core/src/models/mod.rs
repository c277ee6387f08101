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

use crate::float::Float;
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
#[inline]
pub(crate) fn lobe<T: Float>(abs_b: T, a: T, g: &Geometry<T>) -> T {
    (-(abs_b * g.one_minus_cos_gamma().powf(a))).exp()
}
