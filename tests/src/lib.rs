//! Shared fixtures for the cross-checks: the paper's Table 1, the 50-digit reference values
//! of docs/model.md, a deterministic generator and dense direction grids.

use brdf_core::SixParams;

pub use brdf_core::TABLE1;

/// Row `i` of [`TABLE1`] as the `--params` argument of `brdf` (`kb=0.2545,kr=21.8031,...`),
/// each value in its shortest decimal form.
///
/// ```
/// assert_eq!(
///     brdf_tests::table1_params_arg(0),
///     "kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2"
/// );
/// ```
pub fn table1_params_arg(i: usize) -> String {
    let names = brdf_core::ModelKind::Six.param_names();
    names
        .iter()
        .zip(TABLE1[i].1)
        .map(|(n, v)| format!("{n}={v}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// docs/model.md reference values of the six-parameter model (50-digit evaluation rounded to 15
/// significant digits): (theta_i, theta_r, phi in degrees, [khaki, yellow, white]).
pub const SIX_REFERENCE: [(f64, f64, f64, [f64; 3]); 7] = [
    (
        0.0,
        0.0,
        0.0,
        [0.198020580194936, 0.180004240636934, 15.9005019135503],
    ),
    (
        10.0,
        10.0,
        180.0,
        [0.127789612947914, 0.13598092346465, 1.63816561226462],
    ),
    (
        10.0,
        10.0,
        0.0,
        [0.192021427058205, 0.178497558291979, 6.38345406700268],
    ),
    (
        30.0,
        45.0,
        180.0,
        [0.0649636175020779, 0.116091761169466, 0.17724892072584],
    ),
    (
        30.0,
        20.0,
        0.0,
        [0.127415638822464, 0.153251861727361, 0.658696808063585],
    ),
    (
        60.0,
        75.0,
        90.0,
        [0.0100599797939098, 0.108754167953511, 0.121764031119333],
    ),
    (
        0.0,
        89.0,
        180.0,
        [0.000908779161217468, 0.0999772282339606, 0.0750563053192225],
    ),
];

/// docs/model.md reference values of the five-parameter model with khaki's kb, kr, b, a, kd and
/// the V-groove G: (theta_i, theta_r, phi in degrees, value). The first is given to 7 digits.
pub const FIVE_REFERENCE: [(f64, f64, f64, f64); 6] = [
    (0.0, 0.0, 0.0, 0.3480542),
    (10.0, 10.0, 180.0, 0.144675215904701),
    (10.0, 10.0, 0.0, 0.357401620387958),
    (30.0, 45.0, 180.0, 0.10805582325029),
    (30.0, 20.0, 0.0, 0.269976846362571),
    (60.0, 75.0, 90.0, 0.187121763221369),
];

/// Six-parameter struct from a Table 1 row.
pub fn six_params(p: [f64; 6]) -> SixParams<f64> {
    SixParams::from_array(p)
}

/// Degrees to radians in f64.
pub fn rad(deg: f64) -> f64 {
    deg.to_radians()
}

/// Relative difference `|a - b| / |b|` (`|a - b|` when `b == 0`).
pub fn rel_err(a: f64, b: f64) -> f64 {
    if b == 0.0 {
        (a - b).abs()
    } else {
        ((a - b) / b).abs()
    }
}

/// Distance in units in the last place between two finite f64 of the same sign.
pub fn ulps(a: f64, b: f64) -> u64 {
    if a == b {
        return 0;
    }
    (a.to_bits() as i64).abs_diff(b.to_bits() as i64)
}

/// SplitMix64 ([`brdf_core::accuracy::splitmix64`]) for reproducible random cases.
#[derive(Debug, Clone)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        brdf_core::accuracy::splitmix64(&mut self.0)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        brdf_core::accuracy::splitmix64_unit(&mut self.0)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    /// Log-uniform in [lo, hi).
    pub fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }
}

/// A random valid six-parameter set from the ranges the f32 accuracy claim covers (those of
/// the paper's materials, with room): kb in [0.01, 2], kr in [0.05, 50] (log-uniform),
/// b in [-40, 40], a in [0.2, 1], kd in [0, 1], c in [0, 1.5].
pub fn random_six(rng: &mut SplitMix) -> [f64; 6] {
    [
        rng.uniform(0.01, 2.0),
        rng.log_uniform(0.05, 50.0),
        rng.uniform(-40.0, 40.0),
        rng.uniform(0.2, 1.0),
        rng.uniform(0.0, 1.0),
        rng.uniform(0.0, 1.5),
    ]
}

/// The grid of the f32 claim (`brdf_core::accuracy::claim_grid`), collected.
pub fn dense_grid_f32() -> Vec<[f32; 3]> {
    brdf_core::accuracy::claim_grid().collect()
}

/// The three f32 evaluation paths against f64 at the same f32 inputs.
pub mod f32_paths {
    use brdf_core::accuracy::compare;
    use brdf_core::{AnyModel, ModelKind};

    /// One evaluation path: the f32 and the f64 value at one direction.
    pub use brdf_core::accuracy::F32Path as Path;

    /// Worst relative error of `path` over `grid` where the f64 value is above the floor.
    /// Returns (worst relative error, where, number of points compared).
    pub fn worst_error(
        kind: ModelKind,
        params: &[f64],
        grid: &[[f32; 3]],
        path: Path,
    ) -> (f64, [f32; 3], usize) {
        let p32: Vec<f32> = params.iter().map(|&v| v as f32).collect();
        let p64: Vec<f64> = p32.iter().map(|&v| f64::from(v)).collect();
        let m32 = AnyModel::<f32>::new(kind, &p32).unwrap();
        let m64 = AnyModel::<f64>::new(kind, &p64).unwrap();
        let values: Vec<(f32, f64)> = grid.iter().map(|&x| path(&m32, &m64, x)).collect();
        for (x, &(a, b)) in grid.iter().zip(&values) {
            assert!(
                a.is_finite() && b.is_finite(),
                "{kind:?} {params:?} at {x:?}: {a} {b}"
            );
        }
        let a = compare(0..grid.len(), |k| values[k].0, |k| values[k].1);
        (a.max, a.worst_at.map_or([0.0; 3], |k| grid[k]), a.n)
    }

    /// The three paths, by name (`brdf_core::accuracy::F32_PATHS`).
    pub use brdf_core::accuracy::F32_PATHS as PATHS;
}

/// Accuracy of the tabulated path ([`brdf_core::table`]) against the exact f64 model.
pub mod table_error {
    use brdf_core::accuracy::compare;
    use brdf_core::table::{fill_six_table, table_len, SixTable};
    use brdf_core::{Brdf, SixParam};

    /// Maximum and RMS relative error of the f32 table lookup from cosines against the exact
    /// f64 model at the same f32 cosines, over the directions of `grid` (radians) whose
    /// zeniths are at most `max_zenith_deg`, where f64 is above `F32_FLOOR_OF_MAX` of its
    /// maximum. Returns (max, rms, worst direction, points).
    pub fn table_error(
        p: [f64; 6],
        nodes: usize,
        max_zenith_deg: f64,
        grid: &[[f32; 3]],
    ) -> (f64, f64, [f32; 3], usize) {
        let p32 = crate::six_params(p.map(|v| v as f32 as f64));
        let mut bytes = vec![0u8; table_len(nodes)];
        fill_six_table(&p32, nodes, &mut bytes).unwrap();
        let q = brdf_core::SixParams::from_array(p.map(|v| v as f32));
        let table = SixTable::new(q, &bytes).unwrap();
        let exact = SixParam::new(p32).unwrap();
        let max_z = (max_zenith_deg.to_radians()) as f32;
        // The grid holds angles; the worst direction is reported as angles too.
        let dirs: Vec<[f32; 3]> = grid
            .iter()
            .filter(|x| x[0] <= max_z && x[1] <= max_z)
            .copied()
            .collect();
        let cos: Vec<[f32; 3]> = dirs.iter().map(|x| x.map(f32::cos)).collect();
        let a = compare(
            0..cos.len(),
            |k| table.eval_cosines(cos[k][0], cos[k][1], cos[k][2]),
            |k| exact.eval_cosines(cos[k][0].into(), cos[k][1].into(), cos[k][2].into()),
        );
        assert!(
            a.max.is_finite(),
            "{p:?}: non-finite table value at {:?}",
            a.worst_at.map(|k| dirs[k])
        );
        let at = a.worst_at.map_or([0.0; 3], |k| dirs[k]);
        (a.max, a.rms, at, a.n)
    }
}

/// A file of the bundled third-party measurements, `data/measured/<path>` (see
/// `data/README.md`). Tests read only data inside the repository.
pub fn measured(path: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../data/measured")
        .join(path)
}

/// The firmware under QEMU, for the tests that run it.
pub mod qemu {
    use brdf_link::firmware::{Core, Programs};
    use std::path::PathBuf;
    use std::process::Command;
    use std::sync::OnceLock;

    /// Each core's build, run once per test process (`brdf_link::firmware::build`: a no-op
    /// after `cargo xtask test` built the firmware before the tests).
    fn built(core: Core) -> &'static Result<Programs, String> {
        static BUILDS: [OnceLock<Result<Programs, String>>; 3] =
            [OnceLock::new(), OnceLock::new(), OnceLock::new()];
        let k = Core::ALL.iter().position(|&c| c == core).expect("a listed core");
        BUILDS[k].get_or_init(|| brdf_link::firmware::build(core))
    }

    /// Builds the firmware and returns its ELF. Without `qemu-system-arm` or the cross target
    /// this fails the calling test with the command that installs them (`cargo xtask test`
    /// installs both), unless the user opted out with `BRDF_SKIP_QEMU=1`: then it prints a
    /// `SKIPPED:` line and returns `None`.
    pub fn firmware() -> Option<PathBuf> {
        program("brdf-fw")
    }

    /// Binary `bin` of the firmware workspace built for QEMU's Cortex-M4F board, with the
    /// same rules as [`firmware`].
    pub fn program(bin: &str) -> Option<PathBuf> {
        program_for(bin, Core::M4F)
    }

    /// [`program`] built for `core`'s target (to run on its board).
    pub fn program_for(bin: &str, core: Core) -> Option<PathBuf> {
        let skip = std::env::var("BRDF_SKIP_QEMU").as_deref() == Ok("1");
        let qemu = Command::new("qemu-system-arm").arg("--version").output().is_ok();
        if !qemu {
            assert!(
                skip,
                "qemu-system-arm is not installed: run `cargo xtask test`, which installs it, or \
                 `sudo apt-get install qemu-system-arm`; or skip the firmware tests with BRDF_SKIP_QEMU=1"
            );
            eprintln!("SKIPPED: firmware QEMU test (BRDF_SKIP_QEMU=1)");
            return None;
        }
        match built(core) {
            Ok(programs) => Some(
                programs
                    .get(bin)
                    .unwrap_or_else(|| panic!("the firmware build for {} made no `{bin}`", core.target()))
                    .to_path_buf(),
            ),
            Err(why) => {
                let target = core.target();
                assert!(
                    skip,
                    "the firmware did not build for {target}: {why}. Run `cargo xtask test`, which \
                     adds the target, or `rustup target add {target}`; or skip the firmware tests with \
                     BRDF_SKIP_QEMU=1"
                );
                eprintln!("SKIPPED: firmware QEMU test (BRDF_SKIP_QEMU=1)");
                None
            }
        }
    }
}
