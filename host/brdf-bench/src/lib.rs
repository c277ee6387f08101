//! The benchmarks' one home: peers measured in the same run, the measurements, and their
//! text, CSV and chart output. The command lines only parse arguments and print:
//!
//! - `brdf bench fit` ([`fit::MethodBench`]): fitting methods, time against final error over
//!   seeds, with scipy's peers;
//! - `brdf-bench fit DATA.csv` ([`fit::engine_vs_scipy`], run by `bench/fit.sh`): this
//!   engine's default search against scipy's `least_squares` from 32 random starts and
//!   `dual_annealing`, and whether the speed and accuracy goal is reached;
//! - [`peer`]: the scipy fit peer and the numpy evaluation peer (`brdf bench eval`).
//!
//! Nothing here asserts a time: it prints figures and ratios.

pub mod fit;
pub mod peer;
