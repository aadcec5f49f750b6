//! Monte Carlo runs of one scenario with one initializer.
//!
//! ```text
//! cargo run --release -p bearing-slam --example montecarlo -- SCENARIO \
//!     --runs N --init mte|mte-clone|mte-history|pi-sr|pi-sr-mixed \
//!     [--rho-ini R --sigma-rho S] [--seed0 K] [--no-far] [--landmarks N] [--scale F] \
//!     [--slip on|off] [--spec SPEC.json] [--verbose] --json OUT.json
//! ```
//!
//! `pi-sr` uses `--rho-ini`/`--sigma-rho` (default 0.5, 0.25); `pi-sr-mixed`
//! uses them for the near landmarks and (0.01, 0.005) for the scenario's far
//! ones. `--spec` reads a whole `MonteCarloSpec` from JSON instead.
//! `--verbose` prints every run that did not converge with its reason and
//! the filter's initialization events.

use bearing_slam::core::init::InverseDepthPrior;
use bearing_slam::montecarlo::{
    InitializerSpec, MonteCarloReport, MonteCarloSpec, RunClass, run_records,
};
use indicatif::{ProgressBar, ProgressStyle};
use std::process::ExitCode;

fn usage() -> String {
    "usage: montecarlo SCENARIO --runs N --init mte|mte-clone|mte-history|pi-sr|pi-sr-mixed \
     [--rho-ini R --sigma-rho S] [--seed0 K] [--no-far] [--landmarks N] [--scale F] [--slip on|off] \
     [--spec SPEC.json] [--verbose] --json OUT.json"
        .into()
}

struct Args {
    spec: MonteCarloSpec,
    json: Option<String>,
    verbose: bool,
}

fn parse() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let mut scenario = None;
    let (mut runs, mut init, mut rho, mut sigma, mut seed0) =
        (20usize, "mte".to_owned(), 0.5, 0.25, 0u64);
    let (mut no_far, mut landmarks, mut slip, mut json, mut spec_path, mut verbose) =
        (false, None, None, None, None, false);
    let mut scale = None;
    let num = |v: Option<String>, what: &str| -> Result<f64, String> {
        v.ok_or(format!("{what} needs a value"))?
            .parse::<f64>()
            .map_err(|e| format!("{what}: {e}"))
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--runs" => runs = num(args.next(), "--runs")? as usize,
            "--init" => init = args.next().ok_or("--init needs a value")?,
            "--rho-ini" => rho = num(args.next(), "--rho-ini")?,
            "--sigma-rho" => sigma = num(args.next(), "--sigma-rho")?,
            "--seed0" => seed0 = num(args.next(), "--seed0")? as u64,
            "--no-far" => no_far = true,
            "--landmarks" => landmarks = Some(num(args.next(), "--landmarks")? as usize),
            "--scale" => scale = Some(num(args.next(), "--scale")?),
            "--slip" => {
                slip = Some(match args.next().as_deref() {
                    Some("on") => true,
                    Some("off") => false,
                    _ => return Err("--slip takes on or off".into()),
                })
            }
            "--json" => json = Some(args.next().ok_or("--json needs a path")?),
            "--spec" => spec_path = Some(args.next().ok_or("--spec needs a path")?),
            "--verbose" => verbose = true,
            "-h" | "--help" => return Err(usage()),
            s if s.starts_with("--") => return Err(format!("unknown option {s}\n{}", usage())),
            s => scenario = Some(s.to_owned()),
        }
    }
    if let Some(p) = spec_path {
        let text = std::fs::read_to_string(&p).map_err(|e| format!("{p}: {e}"))?;
        let spec = serde_json::from_str(&text).map_err(|e| format!("{p}: {e}"))?;
        return Ok(Args {
            spec,
            json,
            verbose,
        });
    }
    let scenario = scenario.ok_or_else(usage)?;
    let initializer = match init.as_str() {
        "mte" => InitializerSpec::Mte,
        "mte-clone" => InitializerSpec::MteClone,
        "mte-history" => InitializerSpec::MteHistory,
        "pi-sr" => InitializerSpec::PiSr {
            rho_ini: rho,
            sigma_rho: sigma,
        },
        "pi-sr-mixed" => InitializerSpec::PiSrMixed {
            near: InverseDepthPrior {
                rho_ini: rho,
                sigma_rho: sigma,
            },
            far: InverseDepthPrior {
                rho_ini: 0.01,
                sigma_rho: 0.005,
            },
            far_ids: None,
        },
        other => return Err(format!("unknown initializer {other}\n{}", usage())),
    };
    let mut spec = MonteCarloSpec::new(&scenario, initializer, runs);
    spec.scenario.seed0 = seed0;
    spec.scenario.far_landmark = !no_far;
    spec.scenario.landmark_count = landmarks;
    spec.scenario.slip = slip;
    spec.scenario.landmark_scale = scale;
    Ok(Args {
        spec,
        json,
        verbose,
    })
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let spec = &args.spec;
    let bar = ProgressBar::new(spec.runs as u64);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} runs, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(format!(
        "{} / {}",
        spec.scenario.name,
        spec.initializer.label()
    ));
    let records = run_records(spec, |done| bar.set_position(done as u64));
    bar.finish();
    if args.verbose {
        for r in records
            .iter()
            .filter(|r| r.metrics.class != RunClass::Converged)
        {
            println!(
                "run {} (seed {}): {:?}: {}",
                r.metrics.run_index,
                r.metrics.seed,
                r.metrics.class,
                r.metrics.reason.as_deref().unwrap_or("")
            );
            for e in &r.init_events {
                println!("    {e}");
            }
        }
    }
    let report = match MonteCarloReport::from_records(spec, records) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("aggregation failed: {e}");
            return ExitCode::FAILURE;
        }
    };
    let f = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.3}"));
    println!(
        "{} / {}: {} runs: converged {:.1} %, drift {:.1} %, diverged {:.1} %",
        spec.scenario.name,
        report.label,
        spec.runs,
        100.0 * report.converged_fraction,
        100.0 * report.drift_fraction,
        100.0 * report.diverged_fraction
    );
    println!(
        "ATE {} m (dead reckoning {} m), final position {} m, heading {}°, mean NEES {}, NEES in 95 % band {} of the time",
        f(report.all_finite.ate_rmse_m),
        f(report.all_finite.dead_reckoning_ate_rmse_m),
        f(report.all_finite.final_position_error_m),
        f(report.all_finite.final_heading_error_deg),
        f(report.mean_nees),
        f(report.nees_over_time.fraction_inside),
    );
    if let Some(path) = &args.json {
        let text = match report.to_json() {
            Ok(t) => t,
            Err(e) => {
                eprintln!("serialization failed: {e}");
                return ExitCode::FAILURE;
            }
        };
        if let Err(e) = std::fs::write(path, text) {
            eprintln!("{path}: {e}");
            return ExitCode::FAILURE;
        }
        println!("wrote {path}");
    }
    ExitCode::SUCCESS
}
