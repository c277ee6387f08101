//! The device cost figures `brdf select` ranks by (`brdf_core::cost`) against a fresh count
//! under QEMU (`firmware/brdf-fw/src/bin/cost.rs`, `-icount shift=0`: exact and repeatable).

use brdf_core::cost::{exact_instructions, COST_DRIFT, FAST_SIX_INSTRUCTIONS, TABLE_INSTRUCTIONS};
use brdf_core::ModelKind;

#[test]
fn device_cost_constants_match_a_fresh_count() {
    let Some(cost) = brdf_tests::qemu::program("brdf-fw", "cost") else {
        return;
    };
    let counts = brdf_link::instruction_counts(&cost).unwrap();
    let measured = |name: &str| -> f64 {
        counts
            .iter()
            .find(|c| c.0 == name)
            .map(|c| c.1)
            .unwrap_or_else(|| panic!("no `{name}` in {counts:?}"))
    };
    let expected = [
        (
            "lambert exact from cosines",
            exact_instructions(ModelKind::Lambert),
        ),
        (
            "minnaert exact from cosines",
            exact_instructions(ModelKind::Minnaert),
        ),
        ("five exact from cosines", exact_instructions(ModelKind::Five)),
        ("six exact from cosines", exact_instructions(ModelKind::Six)),
        (
            "six-cos2 exact from cosines",
            exact_instructions(ModelKind::SixCos2),
        ),
        (
            "six table 256 from cosines, rebound per query",
            TABLE_INSTRUCTIONS,
        ),
        ("six fast from cosines", FAST_SIX_INSTRUCTIONS),
    ];
    for (name, constant) in expected {
        let m = measured(name);
        println!("{name}: measured {m}, constant {constant}");
        let drift = (m - f64::from(constant)).abs() / f64::from(constant);
        assert!(
            drift <= COST_DRIFT,
            "{name}: measured {m}, brdf_core::cost says {constant}"
        );
    }
}
