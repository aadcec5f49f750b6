//! The speed readings of a frames directory (`speeds.txt`,
//! [`crate::frames::SPEEDS_FILE`]), in either of two forms:
//!
//! - **one column**, one speed per frame (m/s): the speed over the interval
//!   ending at that frame (frame 0's is not used);
//! - **two columns**, `time speed` per line, at the sensor's own rate (a
//!   car's wheel speed on its CAN bus, 50–100 Hz, not in step with the
//!   camera), times in the frames' clock (`times.txt`) and increasing.
//!   They are resampled to the frame intervals: the speed over the interval
//!   `[t_{k−1}, t_k]` ending at frame `k` is the mean of the readings'
//!   piecewise-linear interpolation over it, so that it times the interval
//!   is the distance the interpolated speed covers, the step length the
//!   filter's speed update measures (`‖v_k‖ Δt` under (25)).
//!
//! A speed that is negative or not finite, a time that does not increase,
//! or readings that do not cover every frame interval after the first frame
//! are errors naming the file and the line or frame.

use crate::error::{Result, VisionError};
use crate::frames::{numeric_rows, read_text};
use std::path::Path;

/// Reads `path` in either form and returns one speed per frame of
/// `frame_times` (frame 0's `NaN` for timestamped readings, which say
/// nothing of an interval before it).
pub fn read_speeds(path: &Path, frame_times: &[f64]) -> Result<Vec<f64>> {
    let columns = first_row_columns(path)?;
    let rows = numeric_rows(path, if columns == 2 { 2 } else { 1 })?;
    let parse = |line: usize, reason: String| VisionError::Parse {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut readings: Vec<(f64, f64)> = Vec::with_capacity(rows.len());
    for (line, v) in &rows {
        let speed = *v.last().unwrap_or(&f64::NAN);
        if !(speed.is_finite() && speed >= 0.0) {
            return Err(parse(
                *line,
                format!("speed {speed} is negative or not finite"),
            ));
        }
        let time = if columns == 2 {
            v[0]
        } else {
            readings.len() as f64
        };
        if !time.is_finite() || readings.last().is_some_and(|&(last, _)| time <= last) {
            return Err(parse(*line, format!("time {time} does not increase")));
        }
        readings.push((time, speed));
    }
    if columns != 2 {
        if readings.len() != frame_times.len() {
            return Err(VisionError::Layout {
                dir: path.parent().unwrap_or(path).to_path_buf(),
                reason: format!(
                    "{} has {} lines but image_l has {} frames",
                    crate::frames::SPEEDS_FILE,
                    readings.len(),
                    frame_times.len()
                ),
            });
        }
        return Ok(readings.into_iter().map(|(_, speed)| speed).collect());
    }
    let mut speeds = vec![f64::NAN; frame_times.len()];
    for (k, pair) in frame_times.windows(2).enumerate() {
        speeds[k + 1] = mean_over(&readings, pair[0], pair[1]).ok_or_else(|| {
            let (first, last) = (readings[0].0, readings[readings.len() - 1].0);
            VisionError::Layout {
                dir: path.parent().unwrap_or(path).to_path_buf(),
                reason: format!(
                    "{} covers {first}–{last} s but frame {} needs {}–{} s",
                    crate::frames::SPEEDS_FILE,
                    k + 1,
                    pair[0],
                    pair[1]
                ),
            }
        })?;
    }
    Ok(speeds)
}

/// How many numbers the first non-empty line of `path` holds.
fn first_row_columns(path: &Path) -> Result<usize> {
    Ok(read_text(path)?
        .lines()
        .find(|line| !line.trim().is_empty())
        .map_or(1, |line| line.split_whitespace().count()))
}

/// The mean over `[a, b]` (`a < b`) of the piecewise-linear function
/// through `readings` (`(time, value)`, times increasing): its exact
/// integral, piece by piece, over `b − a`. `None` when `[a, b]` is not
/// inside the readings' span.
fn mean_over(readings: &[(f64, f64)], a: f64, b: f64) -> Option<f64> {
    let (first, last) = (readings.first()?.0, readings.last()?.0);
    if !(a < b && first <= a && b <= last) {
        return None;
    }
    let at = |i: usize, t: f64| {
        let ((t0, v0), (t1, v1)) = (readings[i], readings[i + 1]);
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    };
    let mut integral = 0.0;
    for i in 0..readings.len() - 1 {
        let (lo, hi) = (readings[i].0.max(a), readings[i + 1].0.min(b));
        if lo < hi {
            integral += 0.5 * (at(i, lo) + at(i, hi)) * (hi - lo);
        }
    }
    Some(integral / (b - a))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_of_a_ramp_is_its_value_at_the_midpoint() {
        let ramp: Vec<(f64, f64)> = (0..11)
            .map(|i| (0.1 * f64::from(i), 1.0 + 0.2 * f64::from(i)))
            .collect();
        // v(t) = 1 + 2t over [0, 1].
        for (a, b) in [(0.0, 1.0), (0.05, 0.33), (0.31, 0.32), (0.2, 0.9)] {
            let mean = mean_over(&ramp, a, b).unwrap();
            assert!((mean - (1.0 + (a + b))).abs() < 1e-12, "[{a}, {b}]: {mean}");
        }
    }

    #[test]
    fn the_mean_of_a_tent_counts_both_sides_of_its_peak() {
        let tent = [(0.0, 0.0), (1.0, 2.0), (2.0, 0.0)];
        assert!((mean_over(&tent, 0.5, 1.5).unwrap() - 1.5).abs() < 1e-12);
        assert!((mean_over(&tent, 0.0, 2.0).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn an_interval_outside_the_readings_has_no_mean() {
        let readings = [(1.0, 3.0), (2.0, 3.0)];
        assert!(mean_over(&readings, 0.5, 1.5).is_none());
        assert!(mean_over(&readings, 1.5, 2.5).is_none());
        assert!(mean_over(&readings, 1.5, 1.5).is_none());
        assert_eq!(mean_over(&readings, 1.0, 2.0), Some(3.0));
    }

    fn written(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("bs_speeds_{}_{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(crate::frames::SPEEDS_FILE);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn timestamped_readings_are_resampled_to_the_frame_intervals() {
        // 50 Hz readings of v(t) = 2 + t, frames at 10 Hz from 0.0 s.
        let text: String = (0..=30)
            .map(|i| {
                let t = 0.02 * f64::from(i);
                format!("{t} {}\n", 2.0 + t)
            })
            .collect();
        let path = written("ramp", &text);
        let frames = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let speeds = read_speeds(&path, &frames).unwrap();
        assert!(speeds[0].is_nan());
        for k in 1..frames.len() {
            let expected = 2.0 + 0.5 * (frames[k - 1] + frames[k]);
            assert!(
                (speeds[k] - expected).abs() < 1e-9,
                "frame {k}: {}",
                speeds[k]
            );
        }
        let late = read_speeds(&path, &[0.0, 0.3, 0.7])
            .unwrap_err()
            .to_string();
        assert!(late.contains("frame 2 needs 0.3–0.7 s"), "{late}");
    }

    #[test]
    fn bad_readings_are_refused_naming_the_line() {
        let back = written("back", "0.0 1.0\n0.1 1.0\n0.1 1.0\n");
        let err = read_speeds(&back, &[0.0, 0.1]).unwrap_err().to_string();
        assert!(
            err.contains("line 3") && err.contains("does not increase"),
            "{err}"
        );
        let negative = written("negative", "0.0 1.0\n0.1 -1.0\n");
        let err = read_speeds(&negative, &[0.0, 0.1]).unwrap_err().to_string();
        assert!(err.contains("line 2") && err.contains("negative"), "{err}");
        let ragged = written("ragged", "0.0 1.0\n0.1\n");
        assert!(read_speeds(&ragged, &[0.0, 0.1]).is_err());
        let short = written("short", "1.0\n");
        let err = read_speeds(&short, &[0.0, 0.1]).unwrap_err().to_string();
        assert!(err.contains("1 lines but image_l has 2 frames"), "{err}");
    }
}
