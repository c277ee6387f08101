//! What one lookup costs on the Cortex-M4F, per model and representation: instructions per
//! evaluation from cosines as the firmware serves EVAL (release, LTO, `opt-level = "s"`;
//! counted exactly under QEMU by `bash bench/firmware_cost.sh`). `brdf select` ranks
//! representations by these figures; the test `tests/tests/firmware_cost.rs` re-counts them
//! under QEMU and fails when one drifts by more than [`COST_DRIFT`].

use crate::model::ModelKind;

/// Instructions per exact f32 evaluation from cosines.
pub const fn exact_instructions(kind: ModelKind) -> u32 {
    match kind {
        ModelKind::Lambert => 59,
        ModelKind::Minnaert => 141,
        ModelKind::Ggx => 130,
        ModelKind::Five => 261,
        ModelKind::Six => 366,
        ModelKind::SixCos2 => 391,
    }
}

/// Instructions per tabulated six-parameter lookup from cosines as the firmware serves it
/// (table constants rebound to the blob per query); independent of the node count.
pub const TABLE_INSTRUCTIONS: u32 = 215;

/// Instructions per fitted-table correction as the firmware serves it (its header read once,
/// rebound to the blob per query; `brdf_core::fitted::Corrected`), over and above its base
/// model's [`exact_instructions`]; independent of the table's shape.
pub const FITTED_INSTRUCTIONS: u32 = 680;

/// Relative drift of a measured count from these constants that the test tolerates (a
/// compiler update moves counts by a few percent; a change of method moves them by
/// far more).
pub const COST_DRIFT: f64 = 0.10;
