use brdf_core::ModelKind;
use brdf_fit::import::{import, Channel, Format};
use brdf_fit::{fit, Dataset, FitOptions, Problem, Residual};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (file, fmt, ch, ti, model) = (
        &args[1],
        &args[2],
        &args[3],
        args[4].parse::<f64>().unwrap(),
        &args[5],
    );
    let fmt = brdf_fit::import::Format::from_name(fmt).unwrap();
    let ch = match ch.as_str() {
        "G" => Channel::G,
        "B" => Channel::B,
        _ => Channel::R,
    };
    let imp = import(std::path::Path::new(file), fmt, ch).unwrap();
    let d = &imp.datasets[args.get(6).map_or(0, |s| s.parse().unwrap())];
    let d = Dataset {
        name: d.name.clone(),
        points: d
            .points
            .iter()
            .copied()
            .filter(|p| ti < 0.0 || (p.theta_i.to_degrees() - ti).abs() < 0.01)
            .collect(),
    };
    let kind = ModelKind::from_name(model).unwrap();
    let problem = Problem::from_dataset(kind, Residual::Relative, &d);
    let _ = Format::Cornell;
    for q in brdf_fit::grid::grid_starts(&problem, 8) {
        let r = brdf_fit::lm::minimise(
            &problem,
            &q,
            &problem.bounds().0,
            &problem.bounds().1,
            Default::default(),
        );
        println!(
            "grid start {:?} cost {:.6e} -> polished {:.6e} {:?}",
            &q[..6],
            problem.cost(&q),
            r.cost,
            &r.q[..6]
        );
    }
    for seed in 1..=if std::env::var("ONE").is_ok() { 1 } else { 20 } {
        let r = fit(
            &problem,
            &FitOptions {
                seed,
                ..FitOptions::default()
            },
        );
        println!(
            "seed {seed:2} cost {:.9e} conv {} chains {} hops {} agree {} params {:?} {:?} costs {:?}",
            r.cost,
            r.converged,
            r.search.chains,
            r.search.hops,
            r.search.agreeing,
            &r.params[..kind.param_count()],
            r.search.not_converged,
            r.chain_costs
                .iter()
                .map(|c| format!("{c:.4}"))
                .collect::<Vec<_>>()
        );
    }
    let long = FitOptions {
        seed: 1_000_003,
        chains: 48,
        agree: 48,
        min_chains: 48,
        hops: 16,
        anneal: brdf_fit::anneal::AnnealOptions {
            evals: 3000,
            ..Default::default()
        },
        ..FitOptions::default()
    };
    let r = fit(&problem, &long);
    println!(
        "long cost {:.9e} params {:?}",
        r.cost,
        &r.params[..kind.param_count()]
    );
    let mut cs = r.chain_costs.clone();
    cs.sort_by(f64::total_cmp);
    println!(
        "long chain costs {:?}",
        cs.iter().map(|c| format!("{c:.4}")).collect::<Vec<_>>()
    );
}
