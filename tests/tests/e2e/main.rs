//! Cross-checks and end-to-end tests: reference values, accuracy claims, the firmware under QEMU.
//!
//! One test binary for the crate (one link instead of one per file); each module is one
//! concern, run alone with `cargo test -p PACKAGE --test BINARY MODULE::`.

mod batch_accuracy;
mod embed_example;
mod f32_accuracy;
mod firmware_adversarial;
mod firmware_cost;
mod firmware_qemu;
mod firmware_slots;
mod physics;
mod reference_values;
mod table_accuracy;
