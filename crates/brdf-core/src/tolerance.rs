//! Every accuracy figure the project promises, in one place, each with its justification.
//! Tests across the workspace compare against these constants and nothing else.

/// f64 evaluation against the 50-digit reference values of docs/model.md (relative).
///
/// f64 has eps = 2.2e-16; one evaluation takes about 25 roundings and libm calls of at most
/// 1 ulp, and the lobe `exp(-|b| x^a)` multiplies the relative error of its argument by
/// `|b| x^a` (up to 40 for Table 1). That bounds the error near 1e-13; 1e-12 leaves a
/// factor 10 for libm's worst cases while still catching any formula slip (which shows up
/// at 1e-4 or worse).
pub const F64_REFERENCE_REL: f64 = 1e-12;

/// A reference value published with 7 significant digits (docs/model.md's five-parameter value
/// at normal incidence, 0.3480542): half a unit in the 7th digit, relative.
pub const SEVEN_DIGIT_REFERENCE_REL: f64 = 1.5e-7;

/// Largest relative error of any `f32` evaluation path (angles, cosines, vectors) against
/// `f64` evaluated at exactly the same f32-representable inputs and parameters, wherever
/// `f >= F32_FLOOR_OF_MAX * max f`. 2e-6 is about 17 f32 ulp: the roundings of one
/// evaluation (~25 operations at half an ulp) plus the lobe's amplification: the relative
/// error of `exp(-|b| x^a)` is `a |b| x^a` times the relative error of `x = 1 - cos(gamma)`,
/// and `|b| x^a` reaches ~14 where `f` is still above the floor; the diffuse term
/// `(cos ti cos tr)^c` multiplies the relative error of its base by `c`. The claim is
/// validated (test `f32_accuracy`, 24 random sets per model) for the Table 1 sets (measured
/// 5.3e-7) and for parameters in the paper's range with room — `|b| <= 40`, `a <= 1`,
/// `c <= 1.5` (measured up to 5.9e-7 over 150 sets by
/// `cargo run --release -p brdf-tests --example f32_domain -- 150`). It is **not** met
/// everywhere: with `|b| <= 60`, `a <= 2`, `c <= 2` 2 of 150 sets reach 3.1e-6, and over the
/// fitter's whole search box (`a` to 4, `|b|` to 200, `c` to 5) 51 of 150 exceed it, up to
/// 9.5e-6. The f32 elementary functions ([`F32_EXP_ULPS`], [`F32_LN_ULPS`],
/// [`f32_pow_ulps`]) change these figures little: through libm's f32 routines (which round
/// correctly, computing in f64), with the earlier geometry from cosines (two more square
/// roots), they were 4.9e-7, 8.7e-7, 3.5e-6 and 1.0e-5 (60 of 150).
/// `brdf pack` therefore measures each material it packs on the same grid
/// ([`crate::accuracy::f32_claim_accuracy`]) and warns when it exceeds this figure.
/// The textbook forms of `1 - cos(gamma)` and of `1 + (kr^2 - 1) cos(alpha)` miss it by two
/// to three orders of magnitude (docs/model.md); the firmware cross-check holds the device to the
/// same figure.
pub const F32_MAX_REL: f64 = 2e-6;

/// Relative error a blend halfway between two bands (`crate::bands::blend` in f32 at weight
/// 1/2) adds to its two bands' f32 errors: the blend of two positive values each within a
/// relative error `e` is within `e` (a convex combination); its own arithmetic rounds four
/// times (`1 - w`, two products, the sum), each within half an ulp, and the weight's division
/// once (its two subtractions are exact for neighbouring bands, Sterbenz): under
/// `2.5 * f32::EPSILON`, here `4 * f32::EPSILON` (4.8e-7). Away from the midpoint the weight's
/// rounding is amplified by the ratio of the two bands' values, so `brdf check` holds the
/// device to [`F32_MAX_REL`] plus this at band centres and midpoints only.
pub const BAND_BLEND_MAX_REL: f64 = 4.0 * f32::EPSILON as f64;

/// Relative floor below which [`F32_MAX_REL`] is not claimed: values under one millionth of
/// the material's maximum are dominated by absolute rounding of near-cancelled terms and
/// carry no measurable signal for a sensor.
pub const F32_FLOOR_OF_MAX: f64 = 1e-6;

/// Reciprocity of the six-parameter, Minnaert and Lambert models in f64, in ulp of the
/// larger value: the geometry is symmetric in its two directions operation by operation,
/// so the measured gap is 0; 4 ulp leaves room for a compiler reassociating one sum.
pub const RECIPROCITY_ULPS: u64 = 4;

/// Relative accuracy of [`crate::checks::AlbedoRule::DEFAULT`] (8 panels) against a
/// 40-panel rule, for Table 1 materials at incidences 0–80 degrees, random valid
/// six-parameter sets and narrow mirror peaks down to `kr = 0.01` (test
/// `albedo_default_rule_accuracy`; measured 3.4e-10, so 1e-8 leaves a factor 30 for
/// parameter sets the test does not draw).
pub const ALBEDO_DEFAULT_REL: f64 = 1e-8;

/// Two f64 computations of the same quantity by different cancellation-free formulations
/// (other operation order, a few dozen roundings of 1.1e-16, libm calls within 1 ulp) agree
/// to this, relative: geometry from angles, cosines and vectors; the fitting kernels against
/// the core; cached against full annealing energies. A formula slip shows up at 1e-6 or worse.
pub const F64_REFORMULATION_REL: f64 = 1e-12;

/// Albedo of a Minnaert model by the default quadrature rule against its closed form
/// `2 rho0 cos(ti)^(k-1) / (k + 1)`, for `k >= 0.5`: the integrand's `cos(theta_r)^k` has an
/// unbounded derivative at the horizon, which the graded horizon panel resolves to a few
/// 1e-6 (measured); 1e-5 leaves a factor of a few.
pub const MINNAERT_QUADRATURE_REL: f64 = 1e-5;

/// docs/model.md gives khaki's albedo at normal incidence as "about 0.247": three significant
/// digits, so half a unit in the third digit.
pub const MODEL_DOC_ALBEDO_ABS: f64 = 5e-4;

/// Angles written with 8 or 9 significant digits in test fixtures (e.g. 3.14159265 for pi)
/// come back within this many degrees.
pub const PRINTED_ANGLE_DEG: f64 = 1e-5;

/// A table node recomputed in f32 on the device against the node the host wrote (computed in
/// f64, rounded once), relative. The f32 recomputation errs by a few ulp, times the lobe's
/// amplification `|b| u^(4a)` (up to ~100 over the fitter's search box) where the node is
/// still above 1e-30: about 1e-5 at worst. A node of another material differs by 1e-3 or
/// more, so 1e-4 separates the two.
pub const TABLE_NODE_REL: f64 = 1e-4;

/// Zenith limit (degrees) of the table accuracy promise [`TABLE_MAX_REL`]. Beyond it the
/// diffuse table `mu^c` approaches its unbounded slope at the horizon: the error reaches
/// 1e-2 to 1 within 0.1 degree of grazing (`--example table_domain` prints it).
pub const TABLE_MAX_ZENITH_DEG: f64 = 85.0;

/// Maximum relative error of the tabulated path ([`crate::table`]) against the exact f64
/// model, per node count, over zeniths up to [`TABLE_MAX_ZENITH_DEG`] and every azimuth,
/// where `f >= F32_FLOOR_OF_MAX * max f`. Measured (`cargo run --release -p brdf-tests
/// --example table_domain`) over the Table 1 materials and 40 random sets in the paper's
/// range (those of `F32_MAX_REL`): 1.4e-2, 8.4e-4 and 5.4e-5 for 64, 256 and 1024 nodes
/// (white paint, the steepest lobe, sets each worst figure). Linear interpolation error
/// scales as `1/n^2`; the bounds allow 1.8x over the worst set measured, for sets not drawn.
/// 256 nodes (3 KiB per material) meet a 1e-3 budget.
pub const TABLE_MAX_REL: [(usize, f64); 3] = [(64, 2.5e-2), (256, 1.5e-3), (1024, 1e-4)];

/// The promised maximum relative error of `nodes`-node tables ([`TABLE_MAX_REL`]); `None`
/// for a node count without a promise.
pub fn table_max_rel(nodes: usize) -> Option<f64> {
    TABLE_MAX_REL.iter().find(|t| t.0 == nodes).map(|t| t.1)
}

/// Angular filters (`brdf select --max-theta-i 40`) keep points within this many degrees
/// beyond the limit: importers convert radians to degrees (the Cornell 40 deg incidence comes
/// out as 40.000017 deg), and a limit written as 40 means the 40 deg measurements.
pub const ANGLE_FILTER_DEG: f64 = 1e-4;

/// The f64 batch path ([`crate::batch`]) against the scalar f64 path at the same inputs,
/// relative, wherever the scalar value is non-zero. Both evaluate the same formulas in the
/// same order; they differ only in their `exp`, `ln`, `ln_1p` and `sin`/`cos` (each within
/// 2 ulp of libm's, tested in `batch::lanes`) and, on the FMA levels, in fused roundings. As
/// for [`F64_REFERENCE_REL`], the lobe multiplies the error of its exponent by `|b| x^a`
/// (up to 200 over the fitter's search box), which bounds the difference near 1e-13; measured
/// 1.6e-15 over 86,438 directions, three input forms and 43 parameter sets
/// (`tests/tests/batch_accuracy.rs`). The same 1e-12 as against the reference values.
pub const BATCH_F64_REL: f64 = 1e-12;

/// The f32 exponential of `brdf_core::float` (`Float::exp` for `f32`) against f64 at the same
/// input, in units of `2^-24` relative. The reduction `x - n ln 2` is good to an ulp of `r`
/// (`ln 2` in two parts), the polynomial to 4e-9, and the result rounds three times near 1:
/// measured 1.50 (test `f32_elementary_functions_within_their_ulps`, 2 million arguments
/// over the whole range and every f32 near the worst, a subnormal result at -88.03); 2
/// leaves room for arguments not drawn. libm's `expf` (0.5) computes
/// in f64, in software on the Cortex-M4F.
pub const F32_EXP_ULPS: f64 = 2.0;

/// The f32 `ln` and `ln_1p` of `brdf_core::float` against f64, in units of `2^-24` relative:
/// `t = (m - 1)/(m + 1)` rounds twice (about 2 units), the series and the sum once more.
/// Measured 2.95 for both (`ln` at 1.0079, `ln_1p` at 0.0079, where the result is the series
/// alone; the test draws every f32 around both); 3.5 leaves room for arguments not drawn.
pub const F32_LN_ULPS: f64 = 3.5;

/// The f32 `powf` of `brdf_core::float` (`x^y`, `|y| <= 16`) against f64 at the same inputs,
/// in units of `2^-24` relative. The exponent `y log2 x` is carried in two parts, so its
/// large integer part adds no error; what grows with `|y|` is `y` times the error of `log2`
/// of the mantissa (at most 1.02 units of its size, over every mantissa) and the roundings
/// of `y s` and of the small part (0.35 and 0.4 units per unit of `|y|`): `1.77 |y|` at
/// worst, plus about 1.5 units from the reduction, the polynomial and the final product.
/// Measured (test `f32_elementary_functions_within_their_ulps`: a spread of bases and the
/// mantissas near `sqrt(2)` and `sqrt(1/2)`, where `log2 m` is largest, for 101 exponents
/// in [-16, 16]) up to 25.2 at `|y| = 16` (`0.2 + 1.56 |y|`) and 1.53 at small `|y|`. For
/// the model's `c <= 1.5` the bound is 4.7 units (2.8e-7); libm's `powf` rounds correctly,
/// but computes in f64.
pub fn f32_pow_ulps(y: f64) -> f64 {
    2.0 + 1.8 * y.abs()
}

/// Relative agreement, in units of the precision's epsilon, of two ways of writing one
/// direction pair ([`crate::Geometry::same_pair`]): 64 ulp covers the few roundings by which
/// `phi` and `360 - phi`, or a pair and its swap, reach each quantity. Every quantity must
/// agree, `1 - cos gamma` and `1 - cos alpha` among them (they change relatively fastest): to
/// 1.4e-14 in f64, where no two directions an instrument tells apart pass for one, and to 7.6e-6
/// in f32 (the device's FIT).
pub const SAME_PAIR_EPS: f64 = 64.0;

/// The embedded engine (`brdf fit --engine embedded`, the on-sensor annealer run on the host)
/// against the full engine on the same data: its RMS relative error at most this many times
/// the full engine's (the cross-check `embedded_within_10_percent_of_host`: a fixed budget of
/// 20,000 f32 evaluations and no polish).
pub const EMBEDDED_RMS_OF_HOST: f64 = 1.10;

/// The embedded engine's linear weight (`kd`) against the full engine's on noise-free-ish
/// synthetic data the weight is well determined by (0.5% noise, 135 points), relative: the
/// annealer's answer is within [`EMBEDDED_RMS_OF_HOST`] in cost, which lets a weight move a
/// few percent; 0.1 is well below the error of a weight clamped to a search bound (50% for
/// `kd` = 20 held at 10).
pub const EMBEDDED_WEIGHT_OF_HOST_REL: f64 = 0.1;

/// The embedded engine's fit of readings multiplied by a constant against its fit of the
/// readings as given, relative: the shape parameters equal, the linear weights multiplied by
/// the constant. The host divides the readings by their largest in f64 before the f32 search
/// (one rounding of 2^-53 each, far below f32's 2^-24, so the f32 samples are the same unless
/// a reading lies within 1e-16 of an f32 rounding boundary) and multiplies the weights back in
/// f64 (two roundings); 1e-12 leaves room and still catches any search that differs.
pub const EMBEDDED_UNIT_SCALE_REL: f64 = 1e-12;
