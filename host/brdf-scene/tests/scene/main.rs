//! Scenes: analytic cross-sections and scene files.
//!
//! One test binary for the crate (one link instead of one per file); each module is one
//! concern, run alone with `cargo test -p PACKAGE --test BINARY MODULE::`.

mod analytic;
mod scene_file;
mod select;
