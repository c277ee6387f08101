//! The fitting library on synthetic and bundled measured data.
//!
//! One test binary for the crate (one link instead of one per file); each module is one
//! concern, run alone with `cargo test -p PACKAGE --test BINARY MODULE::`.

mod embedded;
mod import_measured;
mod invariance;
mod large;
mod noise_floor;
mod outliers;
mod real_data;
mod real_data_cases;
mod report_json;
mod stop;
mod targets;
mod threads;
