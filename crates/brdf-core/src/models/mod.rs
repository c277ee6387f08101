//! The model family, one file per model, each generic over `f32` and `f64`.

mod five;
mod ggx;
mod lambert;
mod minnaert;
mod six;
mod six_cos2;

pub use five::{FiveParam, FiveParams};
pub use ggx::{Ggx, GgxParams};
pub use lambert::{Lambert, LambertParams};
pub use minnaert::{Minnaert, MinnaertParams};
pub use six::{SixParam, SixParams};
pub use six_cos2::SixParamCos2;

/// Table 1 of the paper (Yang, Wu and Cao 2012): the six parameters `[kb, kr, b, a, kd, c]`
/// fitted to three painted plates, by material name. Every test, benchmark, example and
/// firmware measurement that needs "the paper's materials" reads them here.
pub const TABLE1: [(&str, [f64; 6]); 3] = [
    ("khaki", [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2000]),
    ("yellow", [0.1932, 11.8999, -39.5679, 0.8295, 0.3723, 0.0420]),
    ("white", [49.3261, 0.1020, -35.4609, 0.6465, 0.6268, 0.2415]),
];

/// Row `i` of [`TABLE1`] (0 khaki, 1 yellow, 2 white) in `f32`, usable in `const` items.
///
/// Each value is the `f64` entry rounded to `f32`, which for these 18 decimals is bit for bit
/// the `f32` literal of the same digits (a unit test checks it). Panics at compile time (in a
/// `const`) or at run time if `i > 2`.
pub const fn table1_f32(i: usize) -> [f32; 6] {
    let r = TABLE1[i].1;
    [
        r[0] as f32,
        r[1] as f32,
        r[2] as f32,
        r[3] as f32,
        r[4] as f32,
        r[5] as f32,
    ]
}

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

#[cfg(test)]
mod table1_tests {
    use super::{table1_f32, TABLE1};

    /// The `f32` rows equal the `f32` literals of the paper's digits: rounding the decimal to
    /// `f64` first and then to `f32` changes none of the 18 values.
    #[test]
    fn table1_f32_equals_f32_literals() {
        let literals: [[f32; 6]; 3] = [
            [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2000],
            [0.1932, 11.8999, -39.5679, 0.8295, 0.3723, 0.0420],
            [49.3261, 0.1020, -35.4609, 0.6465, 0.6268, 0.2415],
        ];
        for (i, row) in literals.iter().enumerate() {
            assert_eq!(
                table1_f32(i).map(f32::to_bits),
                row.map(f32::to_bits),
                "{}",
                TABLE1[i].0
            );
        }
        assert_eq!(TABLE1.map(|(name, _)| name), ["khaki", "yellow", "white"]);
    }
}
