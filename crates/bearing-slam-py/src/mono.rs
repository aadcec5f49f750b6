//! Monocular SLAM on image sequences (issue 17): the frame loop of
//! bearing-slam-vision over the core's `MonoSlam`, and the synthetic
//! renderer. Configurations cross as JSON (the serde types of the Rust
//! crates); results as a dict of numpy arrays.

use crate::convert::arr2;
use crate::errors::{io, raise, slam};
use bearing_slam::io::mono_view::{MonoFrameView, SearchMark, write_mono_mcap};
use bearing_slam_vision::search::{SearchOutcome, chi2_quantile_2dof};
use bearing_slam_vision::{MonoOutput, MonoRunConfig, SyntheticConfig, VisionError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Maps a front-end error to its Python class.
fn vision(e: VisionError) -> PyErr {
    match e {
        VisionError::Filter(inner) => slam(inner),
        VisionError::InvalidParameter { .. } => raise("InvalidParameterError", e.to_string()),
        VisionError::Alignment(_) | VisionError::Contract(_) => {
            raise("MismatchError", e.to_string())
        }
        _ => raise("DatasetError", e.to_string()),
    }
}

fn parse<T: serde::de::DeserializeOwned + Default>(json: Option<&str>, what: &str) -> PyResult<T> {
    match json {
        None => Ok(T::default()),
        Some(text) => serde_json::from_str(text)
            .map_err(|e| raise("InvalidParameterError", format!("{what}: {e}"))),
    }
}

/// Runs monocular SLAM on a frames directory (KITTI clip layout) and
/// returns a dict of numpy arrays and the metrics as JSON; with `mcap`,
/// also writes the run's MCAP for Foxglove there (images, camera paths,
/// the map after every frame: `bearing_slam_io::mono_view`); see
/// `bearing_slam.mono.run`.
#[pyfunction]
#[pyo3(signature = (frames_dir, calib = None, config_json = None, mcap = None))]
pub(crate) fn mono_run<'py>(
    py: Python<'py>,
    frames_dir: PathBuf,
    calib: Option<PathBuf>,
    config_json: Option<&str>,
    mcap: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut config: MonoRunConfig = parse(config_json, "mono config")?;
    if mcap.is_some() {
        config.front_end.record_maps = true;
    }
    let out = py
        .detach(|| bearing_slam_vision::run_directory(&frames_dir, calib.as_deref(), &config))
        .map_err(vision)?;
    if let Some(path) = &mcap {
        py.detach(|| write_run_mcap(path, &out, &config))?;
    }
    let pose_rows = |poses: &[bearing_slam::core::mono::CameraPose]| -> Vec<f64> {
        poses
            .iter()
            .flat_map(|p| {
                let q = p.orientation.quaternion();
                [p.position.x, p.position.y, p.position.z, q.w, q.i, q.j, q.k]
            })
            .collect()
    };
    let stats: Vec<f64> = out
        .run
        .frames
        .iter()
        .enumerate()
        .flat_map(|(k, f)| {
            [
                (k + out.first_frame) as f64,
                f.load_s,
                f.front_end_s,
                f.filter_s,
                f.regions as f64,
                f.found as f64,
                f.missed as f64,
                f.added as f64,
                f.refreshed as f64,
            ]
        })
        .collect();
    let mut searches = Vec::new();
    for (k, search) in out.run.searches.iter().enumerate() {
        for record in &search.records {
            let r = record.region;
            let s = r.innovation_cov;
            let (status, u, v, score) = match record.outcome {
                SearchOutcome::Found { px, score } => (0.0, px.x, px.y, score),
                SearchOutcome::Missed { best } => (1.0, f64::NAN, f64::NAN, best),
                SearchOutcome::OutOfView => (2.0, f64::NAN, f64::NAN, f64::NAN),
            };
            searches.extend([
                (k + out.first_frame) as f64,
                r.feature_id as f64,
                r.predicted_px.x,
                r.predicted_px.y,
                s[(0, 0)],
                s[(0, 1)],
                s[(1, 1)],
                status,
                u,
                v,
                score,
            ]);
        }
    }
    let added: Vec<f64> = out
        .run
        .added_px
        .iter()
        .enumerate()
        .flat_map(|(k, pxs)| {
            pxs.iter()
                .flat_map(move |p| [(k + out.first_frame) as f64, p.x, p.y])
        })
        .collect();
    let landmarks: Vec<f64> = out
        .landmarks
        .iter()
        .flat_map(|m| {
            let mut row = vec![
                m.feature_id as f64,
                m.position.x,
                m.position.y,
                m.position.z,
            ];
            row.extend(m.covariance.iter().copied());
            row
        })
        .collect();
    let metrics = serde_json::to_string(&out.metrics)
        .map_err(|e| raise("MismatchError", format!("metrics: {e}")))?;
    let config_out = serde_json::to_string(&config)
        .map_err(|e| raise("MismatchError", format!("config: {e}")))?;
    let images: Vec<String> = out
        .sequence
        .images
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let d = PyDict::new(py);
    d.set_item("estimate", arr2(py, pose_rows(&out.run.poses), 7)?)?;
    d.set_item("truth", arr2(py, pose_rows(&out.truth), 7)?)?;
    d.set_item("frames", arr2(py, stats, 9)?)?;
    d.set_item("searches", arr2(py, searches, 11)?)?;
    d.set_item("added", arr2(py, added, 3)?)?;
    d.set_item("landmarks", arr2(py, landmarks, 13)?)?;
    d.set_item("metrics_json", metrics)?;
    d.set_item("config_json", config_out)?;
    d.set_item("images", images)?;
    d.set_item("width", out.sequence.width)?;
    d.set_item("height", out.sequence.height)?;
    Ok(d)
}

/// Writes `out` (run with `record_maps` and `config`) as the monocular
/// MCAP at `path`, each search's ellipse at the front end's χ² level.
fn write_run_mcap(
    path: &std::path::Path,
    out: &MonoOutput,
    config: &MonoRunConfig,
) -> PyResult<()> {
    let gate = chi2_quantile_2dof(config.front_end.search.confidence).map_err(vision)?;
    let marks: Vec<Vec<SearchMark>> = out
        .run
        .searches
        .iter()
        .map(|search| {
            search
                .records
                .iter()
                .filter_map(|record| {
                    let found_px = match record.outcome {
                        SearchOutcome::Found { px, .. } => Some(px),
                        SearchOutcome::Missed { .. } => None,
                        SearchOutcome::OutOfView => return None,
                    };
                    Some(SearchMark {
                        predicted_px: record.region.predicted_px,
                        ellipse: record.region.innovation_cov * gate,
                        clip_half_px: config.front_end.search.max_half_axis_px,
                        found_px,
                    })
                })
                .collect()
        })
        .collect();
    let seq = &out.sequence;
    let frames: Vec<MonoFrameView<'_>> = out
        .run
        .poses
        .iter()
        .enumerate()
        .map(|(k, estimate)| MonoFrameView {
            time_s: seq.times[out.first_frame + k],
            image: &seq.images[out.first_frame + k],
            estimate: *estimate,
            truth: out.truth.get(k).copied(),
            map: out.run.maps.get(k).map_or(&[], Vec::as_slice),
            searches: marks.get(k).map_or(&[], Vec::as_slice),
        })
        .collect();
    write_mono_mcap(path, &frames).map_err(io)
}

/// The constant-velocity model's acceleration noise `(σ_a, σ_α)` fitted to
/// the ground-truth poses of a frames directory, with `v` in the frame
/// given as JSON (`"world"` or `"body"`); see
/// `bearing_slam.mono.motion_noise`.
#[pyfunction]
#[pyo3(signature = (frames_dir, velocity_frame_json, calib = None))]
pub(crate) fn mono_motion_noise(
    frames_dir: PathBuf,
    velocity_frame_json: &str,
    calib: Option<PathBuf>,
) -> PyResult<(f64, f64)> {
    let frame = serde_json::from_str(velocity_frame_json)
        .map_err(|e| raise("InvalidParameterError", format!("velocity_frame: {e}")))?;
    let seq =
        bearing_slam_vision::FrameSequence::open(&frames_dir, calib.as_deref()).map_err(vision)?;
    let model = bearing_slam::core::mono::motion_noise_from_truth(&seq.poses, &seq.times, frame)
        .map_err(slam)?;
    Ok((model.linear_accel_sigma, model.angular_accel_sigma))
}

/// Renders the synthetic room sequence into `out_dir` in the KITTI clip
/// layout; returns the number of frames written.
#[pyfunction]
#[pyo3(signature = (out_dir, config_json = None))]
pub(crate) fn mono_render(
    py: Python<'_>,
    out_dir: PathBuf,
    config_json: Option<&str>,
) -> PyResult<usize> {
    let config: SyntheticConfig = parse(config_json, "synthetic config")?;
    let seq = py
        .detach(|| bearing_slam_vision::render_sequence(&config, &out_dir))
        .map_err(vision)?;
    Ok(seq.len())
}
