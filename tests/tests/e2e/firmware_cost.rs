//! The device cost figures `brdf select` ranks by (`brdf_core::cost`) against a fresh count
//! under QEMU (`firmware/core-cost/src/bin/cost.rs`, `-icount shift=0`: exact and repeatable).

use brdf_core::cost::{exact_instructions, COST_DRIFT, FITTED_INSTRUCTIONS, TABLE_INSTRUCTIONS};
use brdf_core::ModelKind;

#[test]
fn device_cost_constants_match_a_fresh_count() {
    let Some(cost) = brdf_tests::qemu::program("cost") else {
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
        ("ggx exact from cosines", exact_instructions(ModelKind::Ggx)),
        ("six exact from cosines", exact_instructions(ModelKind::Six)),
        (
            "six-cos2 exact from cosines",
            exact_instructions(ModelKind::SixCos2),
        ),
        (
            "six table 256 from cosines, rebound per query",
            TABLE_INSTRUCTIONS,
        ),
        (
            "ggx + fitted table from cosines, rebound per query",
            exact_instructions(ModelKind::Ggx) + FITTED_INSTRUCTIONS,
        ),
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

/// The same cost program on the Cortex-M33 and the Cortex-M0+ (`bench/firmware_cost.sh`
/// prints these figures for the docs). The M33's FPU runs the same single-precision
/// instructions as the M4F's, so every path costs within [`COST_DRIFT`] of the M4F figure; the
/// M0+ has no FPU, so every path that does floating-point work costs many times more (a
/// banded material's per-request set-up, mostly integer work, at least twice).
#[test]
fn other_cores_count_every_path() {
    use brdf_link::firmware::Core;
    let count = |core: Core| {
        let elf = brdf_tests::qemu::program_for("cost", core)?;
        let counts = brdf_link::instruction_counts_on(core, &elf).unwrap();
        assert!(counts.len() >= 15, "{core:?}: {counts:?}");
        Some(counts)
    };
    let Some(m4f) = count(Core::M4F) else {
        return;
    };
    let (Some(m33), Some(m0)) = (count(Core::M33), count(Core::M0Plus)) else {
        return;
    };
    for (name, n4) in &m4f {
        let find = |counts: &[(String, f64)]| {
            counts
                .iter()
                .find(|c| &c.0 == name)
                .map(|c| c.1)
                .unwrap_or_else(|| panic!("no `{name}` in {counts:?}"))
        };
        let (n33, n0) = (find(&m33), find(&m0));
        println!("{name}: M0+ {n0}, M4F {n4}, M33 {n33}");
        assert!(
            (n33 - n4).abs() <= COST_DRIFT * n4,
            "{name}: M33 {n33} against M4F {n4}"
        );
        // Finding a wavelength's bands and building their models is mostly integer work
        // (reading the blob, range checks): slower on the M0+, not by an FPU's factor.
        let floor = if name.contains("found and built") {
            2.0
        } else {
            10.0
        };
        assert!(n0 >= floor * n4, "{name}: M0+ {n0} against M4F {n4}");
    }
}
