//! scratch: dump full RunOutput JSON for bit-identity checks (not committed)
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]
use bearing_slam::core::runner::run;
use bearing_slam::eval::real_data::{EvalOptions, Method, filter_log};
use bearing_slam::sim::{Scenario, simulate};
fn main() {
    let out_dir = std::env::args().nth(1).unwrap();
    let log = simulate(&Scenario::named("paper_fig4", 7).unwrap()).unwrap();
    let config = bearing_slam::default_run_config(&log).unwrap();
    let out = run(&log, &config).unwrap();
    std::fs::write(format!("{out_dir}/fig4.json"), format!("{out:?}")).unwrap();
    let opts = EvalOptions::default();
    let r = bearing_slam::io::mrclam::load_mrclam_with(std::path::Path::new("/work/shared/datasets/mrclam/MRCLAM_Dataset6"), 3, &opts.load).unwrap();
    let log = filter_log(&r, Method::Mte, &opts.parameters).unwrap();
    let config = opts.parameters.run_config(Method::Mte, bearing_slam::Pose2::default()).unwrap();
    let out = run(&log, &config).unwrap();
    std::fs::write(format!("{out_dir}/d6r3.json"), format!("{out:?}")).unwrap();
}
