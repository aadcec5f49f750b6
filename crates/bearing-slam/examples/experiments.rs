//! Reproduces the paper's figures as JSON + markdown tables.
//!
//! ```text
//! cargo run --release -p bearing-slam --example experiments -- \
//!     fig4|fig5|fig8|fig10|all [--runs N] [--seed0 K] --out DIR
//! ```
//!
//! Writes `DIR/fig4.{json,md}`, `DIR/consistency.{json,md}` (from the Fig. 4
//! runs), `DIR/fig5.{json,md}`, `DIR/fig8.{json,md}`, `DIR/fig10.{json,md}`
//! and prints each table. Defaults: 200 runs for Fig. 4, 50 for Figs. 8 and 10.

use bearing_slam::experiments::{
    Progress, consistency_curves, consistency_table, fig4, fig4_table, fig5, fig5_table, fig8,
    fig8_table, fig10, fig10_table, write_outputs,
};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

const USAGE: &str = "usage: experiments fig4|fig5|fig8|fig10|all [--runs N] [--seed0 K] --out DIR";

struct Bars {
    current: Mutex<Option<(String, ProgressBar)>>,
}

impl Bars {
    fn update(&self, what: &str, done: usize, total: usize) {
        let Ok(mut guard) = self.current.lock() else {
            return;
        };
        let fresh = !matches!(&*guard, Some((w, _)) if w == what);
        if fresh {
            if let Some((_, bar)) = guard.take() {
                bar.finish();
            }
            let bar = ProgressBar::new(total as u64);
            bar.set_style(
                ProgressStyle::with_template("{msg:40} [{bar:30}] {pos}/{len} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message(what.to_owned());
            *guard = Some((what.to_owned(), bar));
        }
        if let Some((_, bar)) = &*guard {
            bar.set_position(done as u64);
        }
    }

    fn finish(&self) {
        if let Ok(mut guard) = self.current.lock()
            && let Some((_, bar)) = guard.take()
        {
            bar.finish();
        }
    }
}

fn main() -> ExitCode {
    match real_main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn real_main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let (mut which, mut runs, mut seed0, mut out) = (None, None, 0u64, None);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--runs" => {
                runs = Some(
                    args.next()
                        .and_then(|v| v.parse::<usize>().ok())
                        .ok_or("--runs needs a count")?,
                )
            }
            "--seed0" => {
                seed0 = args
                    .next()
                    .and_then(|v| v.parse::<u64>().ok())
                    .ok_or("--seed0 needs a number")?
            }
            "--out" => out = Some(PathBuf::from(args.next().ok_or("--out needs a dir")?)),
            s if s.starts_with('-') => return Err(format!("unknown option {s}\n{USAGE}")),
            s => which = Some(s.to_owned()),
        }
    }
    let which = which.ok_or(USAGE)?;
    let out = out.ok_or(USAGE)?;
    let bars = Bars {
        current: Mutex::new(None),
    };
    let progress: Progress = &|what, done, total| bars.update(what, done, total);
    let all = which == "all";
    let mut known = false;
    if all || which == "fig4" {
        known = true;
        let r = fig4(runs.unwrap_or(200), seed0, progress).map_err(|e| e.to_string())?;
        bars.finish();
        let table = fig4_table(&r);
        println!("## Fig. 4\n{table}");
        write_outputs(&out, "fig4", &r, &table)?;
        let reports: Vec<_> = r.with_far.iter().chain(&r.without_far).cloned().collect();
        let table = consistency_table(&reports);
        println!("## Consistency (pose NEES, 3 dof)\n\n{table}");
        write_outputs(&out, "consistency", &consistency_curves(&reports), &table)?;
    }
    if all || which == "fig5" {
        known = true;
        let angles = [
            0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0,
            60.0,
        ];
        let r = fig5(1.0, 5.0, &angles, 20_000, seed0).map_err(|e| e.to_string())?;
        let table = fig5_table(&r);
        println!("## Fig. 5\n\n{table}");
        write_outputs(&out, "fig5", &r, &table)?;
    }
    if all || which == "fig8" {
        known = true;
        let r = fig8(&[5, 10, 20, 40], runs.unwrap_or(50), seed0, progress)
            .map_err(|e| e.to_string())?;
        bars.finish();
        let table = fig8_table(&r);
        println!("## Fig. 8 (MTE)\n\n{table}");
        write_outputs(&out, "fig8", &r, &table)?;
    }
    if all || which == "fig10" {
        known = true;
        let r = fig10(runs.unwrap_or(50), seed0, progress).map_err(|e| e.to_string())?;
        bars.finish();
        let table = fig10_table(&r);
        println!("## Fig. 10 (MTE)\n\n{table}");
        write_outputs(&out, "fig10", &r, &table)?;
    }
    if known {
        Ok(())
    } else {
        Err(format!("unknown experiment {which}\n{USAGE}"))
    }
}
