//! A fit uses every core (the global search runs the next chain or hop beside the current
//! one; grid polishes and the report's refits run in parallel) yet gives the same bits for a
//! seed whatever the thread count: every real-data case with every model, and the whole
//! report of one, fitted in a pool of one thread and in a pool of two.

use brdf_core::ModelKind;
use brdf_fit::{fit, fit_all, FitOptions, FitSettings, Problem, Residual};

use crate::real_data_cases::{cases, jobs};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

#[test]
fn one_and_two_threads_give_the_same_fit() {
    let cases = cases();
    let (one, two) = (pool(1), pool(2));
    for (case, model) in jobs(&cases) {
        let problem = Problem::from_dataset(model, Residual::Relative, &case.data);
        let opts = FitOptions {
            seed: 3,
            ..FitOptions::default()
        };
        let mut a = one.install(|| fit(&problem, &opts));
        let mut b = two.install(|| fit(&problem, &opts));
        (a.seconds, b.seconds) = (0.0, 0.0);
        assert_eq!(a, b, "{} with {}", case.name, model.name());
    }
}

#[test]
fn one_and_two_threads_give_the_same_report() {
    let cases = cases();
    let data = &cases[0].data;
    let settings = FitSettings::new(ModelKind::Six);
    let json = |threads: usize| {
        let r = pool(threads).install(|| fit_all(&settings, std::slice::from_ref(data)).unwrap());
        let mut v = serde_json::to_value(&r).unwrap();
        v[0]["seconds"] = serde_json::Value::Null;
        v
    };
    assert_eq!(json(1), json(2), "{}", cases[0].name);
}
