//! The datasets of the real-data search test and of the example that regenerates its golden
//! best costs (`examples/real_data_golden.rs` includes this file): every bundled measured
//! dataset (Garnet Red in R, G and B, Krylon Blue, PTFE at four wavelengths, MERL aluminium),
//! the subsets a user would fit (each incidence alone, the forward half, `theta_i <= 40 deg`)
//! and synthetic cases built to fool the agreement test; each with every model that has more
//! than twice as many points as parameters.

use std::path::Path;

use brdf_core::ModelKind;
use brdf_fit::import::{import, Channel, Format};
use brdf_fit::{synth, Dataset, FitOptions};

/// Seeds every fit is run from.
pub const SEEDS: std::ops::RangeInclusive<u64> = 1..=20;

/// Two fits reach "the same optimum" when their costs agree to this relative difference
/// (the LM polish stops at 1e-12 relative cost change; 1e-6 is far above its noise and far
/// below any distinct local optimum seen on these data, the nearest at 8e-5).
pub const SEED_COST_REL: f64 = 1e-6;

/// The golden best costs, relative to this crate's directory.
pub const GOLDEN: &str = "tests/golden/real_data_best_costs.csv";

/// One dataset a user would fit.
pub struct Case {
    pub name: String,
    pub data: Dataset,
}

fn keep(d: &Dataset, name: &str, f: impl Fn(&brdf_fit::Point) -> bool) -> Case {
    Case {
        name: name.to_owned(),
        data: Dataset {
            name: name.to_owned(),
            points: d.points.iter().copied().filter(|p| f(p)).collect(),
        },
    }
}

/// The full dataset, each incidence alone, the forward half-space and `theta_i <= 40 deg`.
fn subsets(d: &Dataset, label: &str, singles: bool) -> Vec<Case> {
    let mut out = vec![keep(d, label, |_| true)];
    if singles {
        for ti in d.incidences() {
            let deg = ti.to_degrees();
            out.push(keep(d, &format!("{label} ti={deg:.2}"), |p| {
                (p.theta_i - ti).abs() < 1e-9
            }));
        }
    }
    out.push(keep(d, &format!("{label} forward"), |p| p.phi.cos() < 0.0));
    out.push(keep(d, &format!("{label} ti<=40"), |p| {
        p.theta_i.to_degrees() <= 40.0 + 1e-4
    }));
    out
}

fn measured(path: &str, format: Format, channel: Channel) -> Vec<Dataset> {
    // Positive readings only: the golden costs were measured before dark readings were kept
    // (a fit with them weighs them with a noise floor, tested in `noise_floor`).
    import(Path::new(&brdf_tests::measured(path)), format, channel)
        .unwrap()
        .positive_only()
        .datasets
}

/// Every case: the measured ones, then the synthetic ones.
pub fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let cornell = "cornell-medium-gloss-paints";
    for (file, channel, label, singles) in [
        ("garnet_red_RGB.astm", Channel::R, "garnet R", true),
        ("garnet_red_RGB.astm", Channel::G, "garnet G", false),
        ("garnet_red_RGB.astm", Channel::B, "garnet B", false),
        ("krylon_blue_RGB.astm", Channel::B, "krylon B", true),
    ] {
        let d = measured(&format!("{cornell}/{file}"), Format::Cornell, channel);
        cases.extend(subsets(&d[0], label, singles));
    }
    let ptfe = measured("ptfe-germer-nist/PTFE.data.csv", Format::Nist, Channel::R);
    for (k, d) in ptfe.iter().enumerate() {
        let wavelength = d.name.rsplit('=').next().unwrap();
        cases.extend(subsets(d, &format!("ptfe {wavelength}"), k == 1));
    }
    let merl = measured(
        "merl-aluminium-inplane/aluminum_brdf.csv",
        Format::MerlInPlane,
        Channel::R,
    );
    cases.extend(subsets(&merl[0], "merl al", true));
    cases.extend(fooling_cases());
    cases
}

/// Synthetic data designed to fool a chain-agreement test.
fn fooling_cases() -> Vec<Case> {
    let ti = [0.0, 20.0, 45.0];
    let mk = |name: &str, p: [f64; 6]| Case {
        name: name.to_owned(),
        data: synth::in_plane(ModelKind::Six, &p, &ti, 2.5, 0.01, 11).unwrap(),
    };
    vec![
        // The optimum has the lobe off: kr, b, a have no effect there.
        mk("lobe off", [0.0, 1.0, -10.0, 1.0, 0.6, 0.4]),
        // A weak, narrow lobe on a diffuse base: the lobe-off fit is a local optimum only
        // a little worse than the true one.
        mk("weak narrow lobe", [0.02, 3.0, -150.0, 1.2, 0.5, 0.3]),
    ]
}

/// Every (case, model) pair fitted: models with more than twice as many points as parameters.
pub fn jobs(cases: &[Case]) -> Vec<(&Case, ModelKind)> {
    cases
        .iter()
        .flat_map(|c| ModelKind::ALL.iter().map(move |&m| (c, m)))
        .filter(|(c, m)| c.data.points.len() > 2 * m.param_count())
        .collect()
}

/// The reference search of the golden costs: `chains` chains, every one run, annealing ten
/// times as long, 16 hops.
#[allow(dead_code)] // used by the example that regenerates the golden file
pub fn long_search(chains: usize) -> FitOptions {
    FitOptions {
        seed: 1_000_003,
        chains,
        agree: chains,
        min_chains: chains,
        hops: 16,
        anneal: brdf_fit::anneal::AnnealOptions {
            evals: 3000,
            ..Default::default()
        },
        ..FitOptions::default()
    }
}

/// Chains of the reference search (every one run, each annealing ten times as long).
#[allow(dead_code)] // used by the example
pub const REFERENCE_CHAINS: usize = 48;

/// The key of a pair in the golden file.
pub fn key(case: &str, model: ModelKind) -> String {
    format!("{case},{}", model.name())
}

/// The golden file's best costs by [`key`]; `Err` names the line that is not `case,model,cost`.
pub fn read_golden(text: &str) -> Result<std::collections::BTreeMap<String, f64>, String> {
    let mut out = std::collections::BTreeMap::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let (k, cost) = line
            .rsplit_once(',')
            .ok_or_else(|| format!("{GOLDEN}: line {}: not case,model,cost", i + 1))?;
        let cost: f64 = cost
            .parse()
            .map_err(|_| format!("{GOLDEN}: line {}: cost `{cost}` is not a number", i + 1))?;
        if out.insert(k.to_owned(), cost).is_some() {
            return Err(format!("{GOLDEN}: line {}: `{k}` twice", i + 1));
        }
    }
    Ok(out)
}
