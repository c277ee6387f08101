//! `brdf synth`: a synthetic dataset from known parameters.

use std::io::Write;

use anyhow::{anyhow, Result};
use brdf_core::ModelKind;
use brdf_fit::synth;
use clap::{Args, ValueEnum};

use crate::common::{parse_fraction, parse_list};
use crate::params::{parse_kind, parse_params};

/// Write a synthetic dataset (CSV on standard output) from a model and parameters, with
/// multiplicative log-normal noise: y = f exp(noise * z), z ~ N(0, 1).
#[derive(Debug, Args)]
pub struct SynthCmd {
    /// Model: six, six-cos2, five, ggx, minnaert, lambert.
    #[arg(long, value_parser = parse_kind)]
    model: ModelKind,
    /// Parameters as name=value pairs.
    #[arg(long, allow_hyphen_values = true)]
    params: String,
    /// Incidence angles, degrees, comma-separated.
    #[arg(long, default_value = "0,10,30")]
    theta_i: String,
    /// Relative noise level, e.g. 2% or 0.02 (at most 100%).
    #[arg(long, value_parser = parse_fraction, default_value = "0")]
    noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// Signed in-plane (theta_i,theta_s,brdf) or full hemisphere (theta_i,theta_r,phi,brdf).
    #[arg(long, value_enum, default_value_t = Form::InPlane)]
    form: Form,
    /// Viewing-angle step, degrees.
    #[arg(long, default_value_t = 5.0)]
    step: f64,
    /// Azimuth step of the full form, degrees.
    #[arg(long, default_value_t = 30.0)]
    phi_step: f64,
}

/// Output layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Form {
    /// theta_i,theta_s,brdf with theta_s > 0 on the forward side.
    InPlane,
    /// theta_i,theta_r,phi,brdf over the hemisphere.
    Full,
}

impl SynthCmd {
    pub fn run(self) -> Result<()> {
        let params = parse_params(self.model, &self.params)?;
        let p = &params[..self.model.param_count()];
        let theta_i = parse_list(&self.theta_i).map_err(|e| anyhow!("--theta-i: {e}"))?;
        if let Some(t) = theta_i.iter().find(|t| !(0.0..90.0).contains(*t)) {
            return Err(anyhow!(
                "--theta-i: {} is outside [0, 90)",
                brdf_core::Compact(*t)
            ));
        }
        let steps_ok =
            self.step >= 0.01 && self.step < 90.0 && self.phi_step >= 0.01 && self.phi_step <= 180.0;
        if !steps_ok {
            return Err(anyhow!(
                "--step must be in [0.01, 90) and --phi-step in [0.01, 180] degrees"
            ));
        }
        // The points are made in memory (56 bytes each) before they are written: bounded.
        let per_incidence = match self.form {
            Form::InPlane => synth::theta_s_grid(self.step).len() as f64,
            Form::Full => {
                (((90.0 - 1e-9) / self.step).floor() + 1.0) * ((180.0 / self.phi_step).floor() + 1.0)
            }
        };
        let points = per_incidence * theta_i.len() as f64;
        if points > MAX_SYNTH_POINTS as f64 {
            return Err(anyhow!(
                "{points:.3e} points asked for (incidences x directions); at most {MAX_SYNTH_POINTS:.0e}: \
                 use coarser steps or fewer incidences"
            ));
        }
        let invalid = |e| anyhow!("invalid parameters for model {}: {e}", self.model.name());
        let stdout = std::io::stdout();
        let mut w = csv::Writer::from_writer(std::io::BufWriter::new(stdout.lock()));
        match self.form {
            Form::InPlane => {
                let d = synth::in_plane(self.model, p, &theta_i, self.step, self.noise, self.seed)
                    .map_err(invalid)?;
                w.write_record(["theta_i", "theta_s", "brdf"])?;
                for pt in &d.points {
                    // Back side is negative; normal viewing stays +0.
                    let ts = if pt.phi > 1.0 {
                        pt.theta_r
                    } else {
                        0.0 - pt.theta_r
                    };
                    w.write_record([fmt_angle(pt.theta_i), fmt_angle(ts), format!("{:.16e}", pt.brdf)])?;
                }
            }
            Form::Full => {
                let d = synth::hemisphere(
                    self.model,
                    p,
                    &theta_i,
                    self.step,
                    self.phi_step,
                    self.noise,
                    self.seed,
                )
                .map_err(invalid)?;
                w.write_record(["theta_i", "theta_r", "phi", "brdf"])?;
                for pt in &d.points {
                    w.write_record([
                        fmt_angle(pt.theta_i),
                        fmt_angle(pt.theta_r),
                        fmt_angle(pt.phi),
                        format!("{:.16e}", pt.brdf),
                    ])?;
                }
            }
        }
        w.flush()?;
        std::io::stdout().flush()?;
        Ok(())
    }
}

/// Most points `brdf synth` makes (about 0.6 GB while they are made): a 1-degree
/// full-hemisphere grid (16,290 directions) at every whole incidence from 0 to 89 is 1.47
/// million.
pub const MAX_SYNTH_POINTS: usize = 10_000_000;

/// Degrees, rounded to 1e-9 so that grid angles print as written.
fn fmt_angle(rad: f64) -> String {
    let d = (rad.to_degrees() * 1e9).round() / 1e9;
    format!("{d}")
}
