// The cargo commands that build the firmware programs, one per target. `xtask` includes this
// file (`include!`) to build them once before the tests; the tests, `brdf bench eval` and
// `brdf_link::firmware::build` run the same commands, which are then no-ops. Run in the
// firmware workspace (`firmware/`).

/// Per target: the cargo arguments that build every program the host runs on it (the whole
/// firmware workspace for the Cortex-M4F; `core-cost` alone for the other cores).
pub const FIRMWARE_BUILDS: [(&str, &[&str]); 3] = [
    (
        "thumbv7em-none-eabihf",
        &["build", "--release", "--target", "thumbv7em-none-eabihf"],
    ),
    (
        "thumbv6m-none-eabi",
        &["build", "--release", "-p", "core-cost", "--target", "thumbv6m-none-eabi"],
    ),
    (
        "thumbv8m.main-none-eabihf",
        &["build", "--release", "-p", "core-cost", "--target", "thumbv8m.main-none-eabihf"],
    ),
];
