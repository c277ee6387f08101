//! `brdf bench`: cost against accuracy, as CSV and charts with the Pareto front marked. The
//! peers (numpy, scipy) and the fitting benchmark live in `brdf_bench`.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use brdf_bench::peer::numpy_eval;
use brdf_core::accuracy::compare;
use brdf_core::batch::{Batch, Level};
use brdf_core::table::{fill_six_table, table_len, SixTable, TABLE_SIZES};
use brdf_core::{AnyModel, Brdf, Float, ModelKind, SixParam, SixParams};
use brdf_fit::{Dataset, Point};
use brdf_plot::{pareto_front, tradeoff, TradePoint};
use clap::{Args, Subcommand};
use rayon::prelude::*;

use brdf_core::batch::par::Inputs;

/// Benchmarks that chart cost against accuracy.
#[derive(Debug, Args)]
pub struct BenchCmd {
    #[command(subcommand)]
    what: BenchWhat,
}

#[derive(Debug, Subcommand)]
enum BenchWhat {
    /// Evaluation variants: host ns and Cortex-M4F instructions per evaluation against max
    /// and RMS relative error versus f64.
    Eval(EvalBench),
    /// Fitting methods: time against final error over seeds.
    Fit(crate::bench_fit::FitBench),
}

impl BenchCmd {
    pub fn run(self) -> Result<()> {
        match self.what {
            BenchWhat::Eval(b) => b.run(),
            BenchWhat::Fit(b) => b.run(),
        }
    }
}

/// Table 1 of the paper.
const MATERIALS: [(&str, [f64; 6]); 3] = brdf_core::TABLE1;

/// Every evaluation path on one material, timed in one run: the scalar path (the device's
/// code) and the batch path (`brdf_core::batch`), f64 and f32, from angles, cosines and unit
/// vectors, on one core and on all cores; the tables at each promised size; Minnaert and
/// Lambert fitted to the six-parameter model standing in for it; and numpy's vectorised f64 evaluation of the same grid
/// (`bench/numpy_eval.py`, run when python3 and numpy are present). Accuracy of every variant
/// is against the f64 scalar path from angles on the same grid (an `N^3` grid of zeniths up
/// to `--max-theta` and azimuths over the circle), where the value is at least 1e-6 of its
/// maximum. Device cost is counted under QEMU (`firmware/core-cost/src/bin/cost.rs`, khaki
/// parameters) when QEMU is present.
#[derive(Debug, Args)]
pub struct EvalBench {
    /// Table 1 material: khaki, yellow or white.
    #[arg(long, default_value = "khaki")]
    material: String,
    /// Largest zenith of the accuracy domain, degrees.
    #[arg(long, default_value_t = 85.0, value_parser = crate::common::degrees(1.0, 90.0))]
    max_theta: f64,
    /// Grid points per axis (theta_i x theta_r x phi = N^3 directions).
    #[arg(long, default_value_t = 100)]
    points: usize,
    /// Timed repetitions of each variant; the fastest counts.
    #[arg(long, default_value_t = 5)]
    reps: usize,
    /// Output directory for eval.csv and the charts.
    #[arg(long, default_value = "docs/bench")]
    out: PathBuf,
    /// Do not count device instructions under QEMU.
    #[arg(long)]
    no_qemu: bool,
    /// Do not run the numpy peer.
    #[arg(long)]
    no_numpy: bool,
    /// Print one JSON object `{"variants": [{name, ns_per_eval, threads, max_rel_error}, ...]}`
    /// instead of the table.
    #[arg(long)]
    json: bool,
}

/// One variant's figures.
#[derive(Debug, serde::Serialize)]
struct Row {
    name: String,
    ns_per_eval: f64,
    threads: usize,
    max_rel_error: f64,
    rms_rel_error: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    device_instructions: Option<f64>,
}

/// Best-of-`reps` nanoseconds per direction of `run`, which evaluates all `n` directions into
/// its output.
fn time_ns(n: usize, reps: usize, run: &mut dyn FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        run();
        best = best.min(t.elapsed().as_secs_f64());
    }
    best * 1e9 / n as f64
}

/// Device instructions per path from the QEMU cost binary, by its path names (the firmware
/// built first: `brdf_link::firmware::build`).
fn device_counts() -> Result<Vec<(String, f64)>> {
    let programs =
        brdf_link::firmware::build(brdf_link::firmware::Core::M4F).map_err(|e| anyhow::anyhow!(e))?;
    let cost = programs
        .get("cost")
        .context("the firmware build made no `cost` program")?;
    Ok(brdf_link::instruction_counts(cost)?)
}

/// Fits `kind` to the six-parameter values at `points` (relative residuals) and returns it.
fn stand_in(kind: ModelKind, points: &[Point]) -> Result<AnyModel<f32>> {
    let d = Dataset {
        name: "six-parameter model".into(),
        points: points.to_vec(),
    };
    let r = brdf_fit::fit_all(&brdf_fit::FitSettings::new(kind), &[d])?
        .pop()
        .ok_or_else(|| anyhow!("no fit"))?;
    let p: Vec<f32> = r.params.0.iter().map(|(_, v)| *v as f32).collect();
    AnyModel::new(kind, &p).map_err(|e| anyhow!("{kind:?} stand-in: {e}"))
}

/// Structure-of-arrays inputs in one precision.
struct Grid<T> {
    angles: [Vec<T>; 3],
    cosines: [Vec<T>; 3],
    wi: [Vec<T>; 3],
    wr: [Vec<T>; 3],
}

fn columns<T: Float>(dirs: &[[f64; 3]], f: impl Fn(&[f64; 3]) -> [f64; 3]) -> [Vec<T>; 3] {
    let rows: Vec<[f64; 3]> = dirs.iter().map(f).collect();
    [0, 1, 2].map(|k| rows.iter().map(|r| T::from_f64(r[k])).collect())
}

fn grid<T: Float>(dirs: &[[f64; 3]]) -> Grid<T> {
    Grid {
        angles: columns(dirs, |a| *a),
        cosines: columns(dirs, |a| a.map(f64::cos)),
        wi: columns(dirs, |a| [a[0].sin(), 0.0, a[0].cos()]),
        wr: columns(dirs, |a| {
            [a[1].sin() * a[2].cos(), a[1].sin() * a[2].sin(), a[1].cos()]
        }),
    }
}

fn refs<T>(c: &[Vec<T>; 3]) -> [&[T]; 3] {
    [&c[0][..], &c[1][..], &c[2][..]]
}

/// Records one variant: name, threads, ns per evaluation, its values (for the error).
type Recorder<'a> = dyn FnMut(String, usize, f64, &[f64]) + 'a;

/// Times the scalar and batch paths of `model` in one precision, one core and all cores.
fn paths<T: Float + Send + Sync>(
    precision: &str,
    model: &AnyModel<T>,
    g: &Grid<T>,
    reps: usize,
    add: &mut Recorder<'_>,
) -> Result<()> {
    let n = g.angles[0].len();
    let threads = rayon::current_num_threads();
    let mut out = vec![T::ZERO; n];
    let scalar = |input: &str, k: usize| -> T {
        match input {
            "angles" => model.eval_angles(g.angles[0][k], g.angles[1][k], g.angles[2][k]),
            "cosines" => model.eval_cosines(g.cosines[0][k], g.cosines[1][k], g.cosines[2][k]),
            _ => model.eval_vectors(
                [g.wi[0][k], g.wi[1][k], g.wi[2][k]],
                [g.wr[0][k], g.wr[1][k], g.wr[2][k]],
            ),
        }
    };
    for input in ["angles", "cosines", "vectors"] {
        for parallel in [false, true] {
            let ns = time_ns(n, reps, &mut || {
                if parallel {
                    out.par_iter_mut()
                        .enumerate()
                        .for_each(|(k, o)| *o = scalar(input, k));
                } else {
                    for (k, o) in out.iter_mut().enumerate() {
                        *o = scalar(input, k);
                    }
                }
                black_box(&out);
            });
            let values: Vec<f64> = out.iter().map(|v| v.to_f64()).collect();
            add(
                format!("{precision} scalar {input}"),
                if parallel { threads } else { 1 },
                ns,
                &values,
            );
        }
    }
    let b = Batch::new(model);
    for input in ["angles", "cosines", "vectors"] {
        let inputs = match input {
            "angles" => Inputs::Angles(refs(&g.angles)),
            "cosines" => Inputs::Cosines(refs(&g.cosines)),
            _ => Inputs::Vectors(refs(&g.wi), refs(&g.wr)),
        };
        for parallel in [false, true] {
            let mut result = Ok(());
            let ns = time_ns(n, reps, &mut || {
                result = brdf_core::batch::par::eval(&b, inputs, &mut out, parallel);
                black_box(&out);
            });
            result.map_err(|e| anyhow!("{precision} batch {input}: {e}"))?;
            let values: Vec<f64> = out.iter().map(|v| v.to_f64()).collect();
            add(
                format!("{precision} batch {input}"),
                if parallel { threads } else { 1 },
                ns,
                &values,
            );
        }
    }
    Ok(())
}

impl EvalBench {
    pub fn run(self) -> Result<()> {
        let (name, p) = MATERIALS
            .iter()
            .find(|m| m.0 == self.material)
            .ok_or_else(|| anyhow!("--material {}: use khaki, yellow or white", self.material))?;
        if self.points < 2 {
            bail!("--points must be at least 2");
        }
        let six32 = SixParams::from_array(p.map(|v| v as f32));
        let six64 = six32.widen();
        let p64 = six64.as_array();
        // The grid of bench/numpy_eval.py: zeniths (k + 1/2)/N of --max-theta, azimuths
        // (k + 1/2)/N of 360 degrees.
        let n_axis = self.points;
        let axis = |k: usize, span: f64| ((k as f64 + 0.5) / n_axis as f64 * span).to_radians();
        let mut dirs = Vec::with_capacity(n_axis.pow(3));
        for i in 0..n_axis {
            for r in 0..n_axis {
                for k in 0..n_axis {
                    dirs.push([axis(i, self.max_theta), axis(r, self.max_theta), axis(k, 360.0)]);
                }
            }
        }
        let n = dirs.len();
        let g64 = grid::<f64>(&dirs);
        let g32 = grid::<f32>(&dirs);
        let exact64 = AnyModel::Six(SixParam::new(six64)?);
        let exact32 = AnyModel::Six(SixParam::new(six32)?);
        let reference: Vec<f64> = (0..n)
            .map(|k| exact64.eval_angles(g64.angles[0][k], g64.angles[1][k], g64.angles[2][k]))
            .collect();
        let points: Vec<Point> = dirs
            .iter()
            .zip(&reference)
            .step_by((n / 8000).max(1))
            .map(|(a, &f)| Point {
                theta_i: a[0],
                theta_r: a[1],
                phi: a[2],
                brdf: f,
                sigma: None,
                weight: None,
                line: 0,
            })
            .collect();
        let minnaert = stand_in(ModelKind::Minnaert, &points)?;
        let ggx = stand_in(ModelKind::Ggx, &points)?;
        let lambert = stand_in(ModelKind::Lambert, &points)?;
        let mut tables = Vec::new();
        for nodes in TABLE_SIZES {
            let mut bytes = vec![0u8; table_len(nodes)];
            fill_six_table(&six64, nodes, &mut bytes)?;
            tables.push((nodes, bytes));
        }
        let counts = if self.no_qemu {
            Vec::new()
        } else {
            device_counts().unwrap_or_else(|e| {
                eprintln_lossy!("device instructions not counted: {e}");
                Vec::new()
            })
        };
        let device = |path: &str| counts.iter().find(|c| c.0 == path).map(|c| c.1);
        // Variant name -> the cost binary's path name.
        let device_of = |name: &str| match name {
            "f32 scalar angles" => device("six exact from angles"),
            "f32 scalar cosines" => device("six exact from cosines"),
            "Minnaert for six, cosines" => device("minnaert exact from cosines"),
            "microfacet for six, cosines" => device("ggx exact from cosines"),
            "Lambert for six, cosines" => device("lambert exact from cosines"),
            t if t.starts_with("f32 table ") => {
                let nodes = t.trim_start_matches("f32 table ").trim_end_matches(" cosines");
                device(&format!("six table {nodes} from cosines"))
            }
            _ => None,
        };

        let mut rows: Vec<Row> = Vec::new();
        let mut add = |name: String, threads: usize, ns: f64, values: &[f64]| {
            let acc = compare(0..values.len(), |k| values[k], |k| reference[k]);
            let device_instructions = if threads == 1 { device_of(&name) } else { None };
            rows.push(Row {
                name,
                ns_per_eval: ns,
                threads,
                max_rel_error: acc.max,
                rms_rel_error: acc.rms,
                device_instructions,
            });
        };
        paths("f64", &exact64, &g64, self.reps, &mut add)?;
        paths("f32", &exact32, &g32, self.reps, &mut add)?;
        let c32 = &g32.cosines;
        let mut single = |name: String, eval: &dyn Fn(usize) -> f32| {
            let mut out = vec![0.0f32; n];
            let ns = time_ns(n, self.reps, &mut || {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = eval(k);
                }
                black_box(&out);
            });
            let values: Vec<f64> = out.iter().map(|&v| f64::from(v)).collect();
            add(name, 1, ns, &values);
        };
        for (nodes, bytes) in &tables {
            let t = SixTable::new(six32, bytes)?;
            single(format!("f32 table {nodes} cosines"), &|k| {
                t.eval_cosines(c32[0][k], c32[1][k], c32[2][k])
            });
        }
        single("Minnaert for six, cosines".into(), &|k| {
            minnaert.eval_cosines(c32[0][k], c32[1][k], c32[2][k])
        });
        single("microfacet for six, cosines".into(), &|k| {
            ggx.eval_cosines(c32[0][k], c32[1][k], c32[2][k])
        });
        single("Lambert for six, cosines".into(), &|k| {
            lambert.eval_cosines(c32[0][k], c32[1][k], c32[2][k])
        });
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("cannot create {}", self.out.display()))?;
        if !self.no_numpy {
            match numpy_eval(self.points, self.max_theta, &p64, &self.out) {
                Ok((ns, values)) => {
                    if values.len() != n {
                        bail!("numpy peer returned {} values for {n} directions", values.len());
                    }
                    add("numpy f64".into(), 1, ns, &values);
                }
                Err(why) => eprintln_lossy!("numpy peer: SKIPPED ({why})"),
            }
        }

        let numpy = rows.iter().find(|r| r.name == "numpy f64").map(|r| r.ns_per_eval);
        let level = Level::detected().name();
        if self.json {
            let v = serde_json::json!({
                "material": name,
                "directions": n,
                "max_theta_deg": self.max_theta,
                "batch_level": level,
                "variants": rows,
            });
            println!("{}", serde_json::to_string_pretty(&v)?);
        }
        // The reference (error 0 by definition) and the all-core rows stay off the charts.
        let charted: Vec<&Row> = rows
            .iter()
            .filter(|r| r.threads == 1 && r.name != "f64 scalar angles" && r.max_rel_error > 0.0)
            .collect();
        let host: Vec<TradePoint> = charted
            .iter()
            .map(|r| TradePoint {
                label: r.name.clone(),
                cost: r.ns_per_eval,
                error: r.max_rel_error,
            })
            .collect();
        let dev: Vec<TradePoint> = rows
            .iter()
            .filter_map(|r| {
                Some(TradePoint {
                    label: r.name.clone(),
                    cost: r.device_instructions?,
                    error: r.max_rel_error,
                })
            })
            .collect();
        let host_front = pareto_front(&host);
        let dev_front = pareto_front(&dev);
        let on = |points: &[TradePoint], front: &[usize], r: &Row| {
            r.threads == 1
                && points
                    .iter()
                    .position(|d| d.label == r.name)
                    .is_some_and(|j| front.contains(&j))
        };
        let csv_path = self.out.join("eval.csv");
        let mut csv = csv::Writer::from_path(&csv_path)
            .with_context(|| format!("cannot write {}", csv_path.display()))?;
        csv.write_record([
            "variant",
            "host_ns",
            "threads",
            "device_instructions",
            "max_rel",
            "rms_rel",
            "pareto_host",
            "pareto_device",
        ])?;
        let mut text = format!(
            "{name}, {n} directions ({}^3 grid, zeniths to {} deg, all azimuths); errors against f64 scalar from angles; batch kernel: {level}\n{:<28} {:>7} {:>9} {:>12} {:>10} {:>10} {:>8}  pareto\n",
            self.points, self.max_theta, "variant", "threads", "host ns", "M4F instr", "max rel", "rms rel", "numpy/x"
        );
        for r in &rows {
            let (h, d) = (on(&host, &host_front, r), on(&dev, &dev_front, r));
            csv.write_record([
                r.name.clone(),
                format!("{:.3}", r.ns_per_eval),
                r.threads.to_string(),
                r.device_instructions.map_or(String::new(), |d| format!("{d}")),
                format!("{:.3e}", r.max_rel_error),
                format!("{:.3e}", r.rms_rel_error),
                h.to_string(),
                d.to_string(),
            ])?;
            text += &format!(
                "{:<28} {:>7} {:>9.2} {:>12} {:>10.2e} {:>10.2e} {:>8}  {}{}\n",
                r.name,
                r.threads,
                r.ns_per_eval,
                r.device_instructions.map_or("-".into(), |d| format!("{d}")),
                r.max_rel_error,
                r.rms_rel_error,
                numpy.map_or("-".into(), |np| format!("{:.1}x", np / r.ns_per_eval)),
                if r.name == "f64 scalar angles" && r.threads == 1 {
                    "reference"
                } else if h {
                    "host "
                } else {
                    ""
                },
                if d { "device" } else { "" }
            );
        }
        csv.flush()?;
        if let Some(np) = numpy {
            let ratio = |name: &str| {
                rows.iter()
                    .find(|r| r.name == name && r.threads == 1)
                    .map_or(f64::NAN, |r| np / r.ns_per_eval)
            };
            text += &format!(
                "goals, one core, numpy f64 / this: f64 batch angles {:.1}x (goal 10x), f32 batch angles {:.1}x (goal 20x)\n",
                ratio("f64 batch angles"),
                ratio("f32 batch angles")
            );
        }
        let title = |what: &str| {
            format!(
                "{name} plate, six-parameter model: {what} against max relative error (zeniths to {} deg)",
                self.max_theta
            )
        };
        for ext in ["svg", "png"] {
            write_chart(
                &self.out.join(format!("eval-host.{ext}")),
                &title("host ns per evaluation"),
                "host ns per evaluation (one core, measured in this run)",
                &host,
            )?;
            if !dev.is_empty() {
                write_chart(
                    &self.out.join(format!("eval-device.{ext}")),
                    &title("Cortex-M4F instructions"),
                    "Cortex-M4F instructions per evaluation (QEMU, exact count)",
                    &dev,
                )?;
            }
        }
        text += &format!(
            "wrote {}/eval.csv and eval-host, eval-device (.svg, .png)",
            self.out.display()
        );
        if self.json {
            eprintln_lossy!("{text}");
        } else {
            println!("{text}");
        }
        Ok(())
    }
}

fn write_chart(path: &Path, title: &str, x: &str, points: &[TradePoint]) -> Result<()> {
    tradeoff(path, title, x, "max relative error against f64", points).map_err(|e| anyhow!("{e}"))
}
