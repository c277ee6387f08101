//! `brdf bench`: cost against accuracy, as CSV and charts with the Pareto front marked.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::fast::FastSix;
use brdf_core::table::{fill_six_table, table_len, SixTable, TABLE_SIZES};
use brdf_core::tolerance::F32_FLOOR_OF_MAX;
use brdf_core::{AnyModel, Brdf, ModelKind, SixParam, SixParams};
use brdf_fit::{Dataset, FitOptions, Point, Residual};
use brdf_plot::{pareto_front, tradeoff, TradePoint};
use clap::{Args, Subcommand};

use crate::fit::fit_all;

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
const MATERIALS: [(&str, [f64; 6]); 3] = [
    ("khaki", [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2]),
    ("yellow", [0.1932, 11.8999, -39.5679, 0.8295, 0.3723, 0.0420]),
    ("white", [49.3261, 0.1020, -35.4609, 0.6465, 0.6268, 0.2415]),
];

/// Every evaluation variant on one material: the exact model in f64 and f32 (from angles and
/// from cosines), the f32 path with this crate's own exp2/log2, the tables at each promised
/// size, and Minnaert and Lambert fitted to the six-parameter model standing in for it.
/// Accuracy is against the f64 six-parameter model from angles on a grid of zeniths up to
/// `--max-theta` and all azimuths; host cost is measured in this run; device cost is counted
/// under QEMU (`firmware/brdf-fw/src/bin/cost.rs`, khaki parameters) when QEMU is present.
#[derive(Debug, Args)]
pub struct EvalBench {
    /// Table 1 material: khaki, yellow or white.
    #[arg(long, default_value = "khaki")]
    material: String,
    /// Largest zenith of the accuracy domain, degrees.
    #[arg(long, default_value_t = 85.0, value_parser = crate::common::degrees(1.0, 90.0))]
    max_theta: f64,
    /// Output directory for eval.csv and the charts.
    #[arg(long, default_value = "docs/bench")]
    out: PathBuf,
    /// Do not count device instructions under QEMU.
    #[arg(long)]
    no_qemu: bool,
}

/// One variant's figures.
struct Row {
    name: String,
    host_ns: f64,
    device: Option<f64>,
    max_rel: f64,
    rms_rel: f64,
}

fn time_ns(n: usize, f: &dyn Fn(usize) -> f64) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        let mut acc = 0.0;
        for k in 0..n {
            acc += f(black_box(k));
        }
        black_box(acc);
        best = best.min(t.elapsed().as_secs_f64());
    }
    best * 1e9 / n as f64
}

/// Device instructions per path from the QEMU cost binary, by its path names.
fn device_counts() -> Result<Vec<(String, f64)>> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware");
    let built = Command::new("cargo")
        .args(["build", "--quiet", "--release", "-p", "brdf-fw", "--bin", "cost"])
        .current_dir(&dir)
        .status()
        .context("cannot run cargo to build the cost firmware")?;
    if !built.success() {
        bail!("the cost firmware did not build (is the thumbv7em-none-eabihf target installed?)");
    }
    Ok(brdf_link::instruction_counts(
        &dir.join("target/thumbv7em-none-eabihf/release/cost"),
    )?)
}

/// Fits `kind` to the six-parameter values at `points` (relative residuals) and returns it.
fn stand_in(kind: ModelKind, points: &[Point]) -> Result<AnyModel<f32>> {
    let d = Dataset {
        name: "six-parameter model".into(),
        points: points.to_vec(),
    };
    let r = fit_all(kind, Residual::Relative, FitOptions::default(), &[d])
        .pop()
        .ok_or_else(|| anyhow!("no fit"))?;
    let p: Vec<f32> = r.params.0.iter().map(|(_, v)| *v as f32).collect();
    AnyModel::new(kind, &p).map_err(|e| anyhow!("{kind:?} stand-in: {e}"))
}

impl EvalBench {
    pub fn run(self) -> Result<()> {
        let (name, p) = MATERIALS
            .iter()
            .find(|m| m.0 == self.material)
            .ok_or_else(|| anyhow!("--material {}: use khaki, yellow or white", self.material))?;
        let six32 = SixParams::from_array(p.map(|v| v as f32));
        let six64 = six32.widen();
        // Grid: 40 x 40 zeniths in (0, max], 36 azimuths in [0, 360).
        let zmax = self.max_theta.to_radians();
        let mut ang = Vec::new();
        for i in 1..=40 {
            for j in 1..=40 {
                for k in 0..36 {
                    ang.push([
                        zmax * f64::from(i) / 40.0,
                        zmax * f64::from(j) / 40.0,
                        (f64::from(k) * 10.0).to_radians(),
                    ]);
                }
            }
        }
        let n = ang.len();
        let a32: Vec<[f32; 3]> = ang.iter().map(|a| a.map(|v| v as f32)).collect();
        let c32: Vec<[f32; 3]> = ang.iter().map(|a| a.map(|v| v.cos() as f32)).collect();
        let exact64 = SixParam::new(six64)?;
        let exact32 = SixParam::new(six32)?;
        let fast = FastSix::new(six32)?;
        let reference: Vec<f64> = ang
            .iter()
            .map(|a| exact64.eval_angles(a[0], a[1], a[2]))
            .collect();
        let points: Vec<Point> = ang
            .iter()
            .zip(&reference)
            .step_by(7)
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
                eprintln!("device instructions not counted: {e}");
                Vec::new()
            })
        };
        let device = |path: &str| counts.iter().find(|c| c.0 == path).map(|c| c.1);

        let floor = F32_FLOOR_OF_MAX * reference.iter().copied().fold(0.0, f64::max);
        let mut rows = Vec::new();
        let mut add = |name: String, device: Option<f64>, f: &dyn Fn(usize) -> f64| {
            let (mut max, mut sum, mut m) = (0.0f64, 0.0, 0usize);
            for (k, &r) in reference.iter().enumerate() {
                if r > floor {
                    let e = ((f(k) - r) / r).abs();
                    max = max.max(e);
                    sum += e * e;
                    m += 1;
                }
            }
            rows.push(Row {
                name,
                host_ns: time_ns(n, f),
                device,
                max_rel: max,
                rms_rel: (sum / m as f64).sqrt(),
            });
        };
        add("f64 exact, angles".into(), None, &|k| {
            let a = ang[k];
            exact64.eval_angles(a[0], a[1], a[2])
        });
        add(
            "f32 exact, angles".into(),
            device("six exact from angles"),
            &|k| {
                let a = a32[k];
                f64::from(exact32.eval_angles(a[0], a[1], a[2]))
            },
        );
        add(
            "f32 exact, cosines".into(),
            device("six exact from cosines"),
            &|k| {
                let c = c32[k];
                f64::from(exact32.eval_cosines(c[0], c[1], c[2]))
            },
        );
        add(
            "f32 own exp2/log2, cosines".into(),
            device("six fast from cosines"),
            &|k| {
                let c = c32[k];
                f64::from(fast.eval_cosines(c[0], c[1], c[2]))
            },
        );
        for (nodes, bytes) in &tables {
            let t = SixTable::new(six32, bytes)?;
            add(
                format!("f32 table {nodes}, cosines"),
                device(&format!("six table {nodes} from cosines")),
                &|k| {
                    let c = c32[k];
                    f64::from(t.eval_cosines(c[0], c[1], c[2]))
                },
            );
        }
        add(
            "Minnaert for six, cosines".into(),
            device("minnaert exact from cosines"),
            &|k| {
                let c = c32[k];
                f64::from(minnaert.eval_cosines(c[0], c[1], c[2]))
            },
        );
        add(
            "Lambert for six, cosines".into(),
            device("lambert exact from cosines"),
            &|k| {
                let c = c32[k];
                f64::from(lambert.eval_cosines(c[0], c[1], c[2]))
            },
        );

        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("cannot create {}", self.out.display()))?;
        // The f64 path is the reference (error 0 by definition): in the table, not the charts.
        let host: Vec<TradePoint> = rows
            .iter()
            .skip(1)
            .map(|r| TradePoint {
                label: r.name.clone(),
                cost: r.host_ns,
                error: r.max_rel,
                worst: None,
            })
            .collect();
        let dev: Vec<TradePoint> = rows
            .iter()
            .filter_map(|r| {
                Some(TradePoint {
                    label: r.name.clone(),
                    cost: r.device?,
                    error: r.max_rel,
                    worst: None,
                })
            })
            .collect();
        let host_front = pareto_front(&host);
        let dev_front = pareto_front(&dev);
        let csv_path = self.out.join("eval.csv");
        let mut csv = csv::Writer::from_path(&csv_path)
            .with_context(|| format!("cannot write {}", csv_path.display()))?;
        csv.write_record([
            "variant",
            "host_ns",
            "device_instructions",
            "max_rel",
            "rms_rel",
            "pareto_host",
            "pareto_device",
        ])?;
        println!(
            "{name}, {n} directions (zeniths to {} deg, all azimuths); errors against f64 from angles",
            self.max_theta
        );
        println!(
            "{:<28} {:>9} {:>12} {:>10} {:>10}  pareto",
            "variant", "host ns", "M4F instr", "max rel", "rms rel"
        );
        for (i, r) in rows.iter().enumerate() {
            let on_dev = dev
                .iter()
                .position(|d| d.label == r.name)
                .is_some_and(|j| dev_front.contains(&j));
            let on_host = i > 0 && host_front.contains(&(i - 1));
            csv.write_record([
                r.name.clone(),
                format!("{:.2}", r.host_ns),
                r.device.map_or(String::new(), |d| format!("{d}")),
                format!("{:.3e}", r.max_rel),
                format!("{:.3e}", r.rms_rel),
                on_host.to_string(),
                on_dev.to_string(),
            ])?;
            println!(
                "{:<28} {:>9.2} {:>12} {:>10.2e} {:>10.2e}  {}{}",
                r.name,
                r.host_ns,
                r.device.map_or("-".into(), |d| format!("{d}")),
                r.max_rel,
                r.rms_rel,
                if i == 0 {
                    "reference"
                } else if on_host {
                    "host "
                } else {
                    ""
                },
                if on_dev { "device" } else { "" }
            );
        }
        csv.flush()?;
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
        println!(
            "wrote {}/eval.csv and eval-host, eval-device (.svg, .png)",
            self.out.display()
        );
        Ok(())
    }
}

fn write_chart(path: &Path, title: &str, x: &str, points: &[TradePoint]) -> Result<()> {
    tradeoff(path, title, x, "max relative error against f64", points).map_err(|e| anyhow!("{e}"))
}
