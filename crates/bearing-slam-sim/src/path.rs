//! Reference paths for the waypoint follower: polylines built from simple
//! shapes (line, circle, oval, rounded rectangle, figure eight) or from
//! waypoints, with arc-length look-ups and a windowed closest-point search that
//! stays on the right branch where a path crosses itself.

use crate::error::{Result, SimError, check_finite, check_positive, invalid};
use bearing_slam_core::Pose2;
use rapier2d_f64::math::Vector;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Spacing of the points of generated curves, metres.
const CURVE_SPACING_M: f64 = 0.02;

/// The shape of a reference path, in world coordinates. Closed shapes start
/// where noted and run counter-clockwise unless said otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum PathSpec {
    /// A straight segment (open).
    Line {
        /// Start `[x, y]`.
        from: [f64; 2],
        /// End `[x, y]`.
        to: [f64; 2],
    },
    /// A polyline through the given points; `closed` joins the last to the first.
    Waypoints {
        /// At least two points `[x, y]`.
        points: Vec<[f64; 2]>,
        /// Whether the path loops back to its first point.
        #[serde(default)]
        closed: bool,
    },
    /// A circle, starting at polar angle `start_angle` around `center`.
    Circle {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Radius, metres.
        radius: f64,
        /// Polar angle of the start point, radians.
        #[serde(default)]
        start_angle: f64,
        /// Counter-clockwise (default) or clockwise.
        #[serde(default = "default_true")]
        ccw: bool,
    },
    /// An oval (stadium): two straights along x of length `straight_m` joined
    /// by half circles of radius `radius`; starts at the middle of the bottom
    /// straight heading +x.
    Oval {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Length of each straight, metres (≥ 0).
        straight_m: f64,
        /// Radius of the end half-circles, metres.
        radius: f64,
    },
    /// A `width × height` rectangle with rounded corners; starts at the middle
    /// of the bottom side heading +x.
    RoundedRect {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Extent along x, metres.
        width: f64,
        /// Extent along y, metres.
        height: f64,
        /// Corner radius, metres (≤ half the smaller side).
        corner_radius: f64,
    },
    /// A figure eight (lemniscate of Gerono `x = A sin t`, `y = A sin t cos t`):
    /// lobes along x, crossing at the centre; starts at the centre heading +45°,
    /// right lobe clockwise, left lobe counter-clockwise.
    FigureEight {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Half width `A` (each lobe spans `A` along x and `A/2` along y).
        half_width: f64,
    },
}

fn default_true() -> bool {
    true
}

fn v(p: [f64; 2]) -> Vector {
    Vector::new(p[0], p[1])
}

impl PathSpec {
    /// Checks the numbers of the shape.
    pub fn validate(&self) -> Result<()> {
        match self {
            Self::Line { from, to } => {
                for (i, x) in from.iter().chain(to.iter()).enumerate() {
                    check_finite(&format!("path.line[{i}]"), *x)?;
                }
                if from == to {
                    return Err(SimError::InvalidScenario(
                        "path: a line needs two distinct end points".into(),
                    ));
                }
            }
            Self::Waypoints { points, .. } => {
                if points.len() < 2 {
                    return Err(SimError::InvalidScenario(
                        "path: waypoints need at least two points".into(),
                    ));
                }
                for (i, p) in points.iter().enumerate() {
                    check_finite(&format!("path.points[{i}].x"), p[0])?;
                    check_finite(&format!("path.points[{i}].y"), p[1])?;
                }
            }
            Self::Circle {
                center,
                radius,
                start_angle,
                ..
            } => {
                check_finite("path.center.x", center[0])?;
                check_finite("path.center.y", center[1])?;
                check_positive("path.radius", *radius)?;
                check_finite("path.start_angle", *start_angle)?;
            }
            Self::Oval {
                center,
                straight_m,
                radius,
            } => {
                check_finite("path.center.x", center[0])?;
                check_finite("path.center.y", center[1])?;
                crate::error::check_non_negative("path.straight_m", *straight_m)?;
                check_positive("path.radius", *radius)?;
            }
            Self::RoundedRect {
                center,
                width,
                height,
                corner_radius,
            } => {
                check_finite("path.center.x", center[0])?;
                check_finite("path.center.y", center[1])?;
                check_positive("path.width", *width)?;
                check_positive("path.height", *height)?;
                check_positive("path.corner_radius", *corner_radius)?;
                if 2.0 * corner_radius > width.min(*height) {
                    return Err(invalid(
                        "path.corner_radius",
                        *corner_radius,
                        "must not exceed half the smaller side",
                    ));
                }
            }
            Self::FigureEight { center, half_width } => {
                check_finite("path.center.x", center[0])?;
                check_finite("path.center.y", center[1])?;
                check_positive("path.half_width", *half_width)?;
            }
        }
        Ok(())
    }

    /// The polyline of the shape and whether it is closed.
    pub fn build(&self) -> Result<Path> {
        self.validate()?;
        let (points, closed) = match self {
            Self::Line { from, to } => (vec![v(*from), v(*to)], false),
            Self::Waypoints { points, closed } => (points.iter().map(|p| v(*p)).collect(), *closed),
            Self::Circle {
                center,
                radius,
                start_angle,
                ccw,
            } => {
                let n = ((TAU * radius / CURVE_SPACING_M).ceil() as usize).max(64);
                let sign = if *ccw { 1.0 } else { -1.0 };
                let pts = (0..n)
                    .map(|k| {
                        let a = start_angle + sign * TAU * k as f64 / n as f64;
                        v(*center) + Vector::new(a.cos(), a.sin()) * *radius
                    })
                    .collect();
                (pts, true)
            }
            Self::Oval {
                center,
                straight_m,
                radius,
            } => (
                rounded_rect(v(*center), straight_m + 2.0 * radius, 2.0 * radius, *radius),
                true,
            ),
            Self::RoundedRect {
                center,
                width,
                height,
                corner_radius,
            } => (
                rounded_rect(v(*center), *width, *height, *corner_radius),
                true,
            ),
            Self::FigureEight { center, half_width } => {
                let n = ((6.1 * half_width / CURVE_SPACING_M).ceil() as usize).max(200);
                let pts = (0..n)
                    .map(|k| {
                        let t = TAU * k as f64 / n as f64;
                        v(*center)
                            + Vector::new(half_width * t.sin(), half_width * t.sin() * t.cos())
                    })
                    .collect();
                (pts, true)
            }
        };
        Path::new(points, closed)
    }
}

/// Points of a rounded rectangle, from the middle of the bottom side, CCW.
fn rounded_rect(center: Vector, width: f64, height: f64, rc: f64) -> Vec<Vector> {
    let hx = 0.5 * width - rc;
    let hy = 0.5 * height - rc;
    let mut pts = vec![center + Vector::new(0.0, -0.5 * height)];
    // Corner centres in CCW order starting bottom-right, with the start angle of each arc.
    let corners = [
        (Vector::new(hx, -hy), -FRAC_PI_2),
        (Vector::new(hx, hy), 0.0),
        (Vector::new(-hx, hy), FRAC_PI_2),
        (Vector::new(-hx, -hy), PI),
    ];
    let n_arc = ((FRAC_PI_2 * rc / CURVE_SPACING_M).ceil() as usize).max(8);
    for (c, a0) in corners {
        for k in 0..=n_arc {
            let a = a0 + FRAC_PI_2 * k as f64 / n_arc as f64;
            let p = center + c + Vector::new(a.cos(), a.sin()) * rc;
            if pts.last().is_none_or(|q: &Vector| (*q - p).length() > 1e-9) {
                pts.push(p);
            }
        }
    }
    // Back along the bottom side to the start: the closing segment does it.
    pts
}

/// Half width `A` of a [`PathSpec::FigureEight`] whose one lap is `length` metres.
#[must_use]
pub fn figure_eight_half_width_for_length(length: f64) -> f64 {
    let n = 20_000;
    let mut perimeter = 0.0;
    let mut prev = Vector::ZERO;
    for k in 1..=n {
        let t = TAU * f64::from(k) / f64::from(n);
        let p = Vector::new(t.sin(), t.sin() * t.cos());
        perimeter += (p - prev).length();
        prev = p;
    }
    length / perimeter
}

/// A polyline path with cumulative arc lengths. A closed path repeats forever
/// in arc length (`s` beyond one lap wraps around).
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    points: Vec<Vector>,
    /// Arc length at each point; one more entry than points when closed.
    cumulative: Vec<f64>,
    closed: bool,
}

impl Path {
    /// A path through `points` (consecutive duplicates removed).
    pub fn new(mut points: Vec<Vector>, closed: bool) -> Result<Self> {
        points.dedup_by(|a, b| (*a - *b).length() < 1e-12);
        if closed && points.len() > 2 && (points[0] - points[points.len() - 1]).length() < 1e-12 {
            points.pop();
        }
        if points.len() < 2 {
            return Err(SimError::InvalidScenario(
                "path: fewer than two distinct points".into(),
            ));
        }
        let mut cumulative = vec![0.0];
        let n_seg = if closed {
            points.len()
        } else {
            points.len() - 1
        };
        for i in 0..n_seg {
            let a = points[i];
            let b = points[(i + 1) % points.len()];
            let last = cumulative[cumulative.len() - 1];
            cumulative.push(last + (b - a).length());
        }
        Ok(Self {
            points,
            cumulative,
            closed,
        })
    }

    /// Whether the path loops.
    #[must_use]
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Length of one lap (or of the whole open path), metres.
    #[must_use]
    pub fn length(&self) -> f64 {
        self.cumulative[self.cumulative.len() - 1]
    }

    fn segment_count(&self) -> usize {
        self.cumulative.len() - 1
    }

    fn segment(&self, i: usize) -> (Vector, Vector) {
        (self.points[i], self.points[(i + 1) % self.points.len()])
    }

    /// The point at arc length `s` (clamped for an open path, wrapped for a
    /// closed one).
    #[must_use]
    pub fn point_at(&self, s: f64) -> Vector {
        let len = self.length();
        let s = if self.closed {
            s.rem_euclid(len)
        } else {
            s.clamp(0.0, len)
        };
        let i = self
            .cumulative
            .partition_point(|&c| c <= s)
            .saturating_sub(1)
            .min(self.segment_count() - 1);
        let (a, b) = self.segment(i);
        let seg_len = self.cumulative[i + 1] - self.cumulative[i];
        let u = if seg_len > 0.0 {
            ((s - self.cumulative[i]) / seg_len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        a + (b - a) * u
    }

    /// The start pose: the first point, heading along the first segment.
    #[must_use]
    pub fn start_pose(&self) -> Pose2 {
        let (a, b) = self.segment(0);
        let d = b - a;
        Pose2::new(a.x, a.y, d.y.atan2(d.x))
    }

    /// The arc length (unrolled over laps for a closed path) of the point of
    /// the path closest to `p`, among segments within `[hint − back, hint + ahead]`.
    #[must_use]
    pub fn closest_near(&self, p: Vector, hint: f64, back: f64, ahead: f64) -> f64 {
        let len = self.length();
        let lo = if self.closed {
            hint - back
        } else {
            (hint - back).max(0.0)
        };
        let hi = if self.closed {
            hint + ahead
        } else {
            (hint + ahead).min(len)
        };
        let lap0 = (lo / len).floor();
        let base_lo = lo - lap0 * len;
        let n = self.segment_count();
        let mut i = self
            .cumulative
            .partition_point(|&c| c <= base_lo)
            .saturating_sub(1)
            .min(n - 1);
        let mut offset = lap0 * len;
        let mut best = (f64::INFINITY, hint);
        // Walk forward through (unrolled) segments until past `hi`.
        for _ in 0..(4 * n + 4) {
            let s0 = offset + self.cumulative[i];
            if s0 > hi {
                break;
            }
            let (a, b) = self.segment(i);
            let d = b - a;
            let l2 = d.length_squared();
            let u = if l2 > 0.0 {
                ((p - a).dot(d) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let s = (s0 + u * l2.sqrt()).clamp(lo, hi);
            let dist = (self.point_at(s) - p).length_squared();
            if dist < best.0 {
                best = (dist, s);
            }
            i += 1;
            if i == n {
                if !self.closed {
                    break;
                }
                i = 0;
                offset += len;
            }
        }
        best.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_have_the_expected_lengths() {
        let c = PathSpec::Circle {
            center: [0.0, 0.0],
            radius: 5.0,
            start_angle: 0.0,
            ccw: true,
        }
        .build()
        .unwrap();
        assert!((c.length() - TAU * 5.0).abs() < 0.01);
        let o = PathSpec::Oval {
            center: [0.0, 0.0],
            straight_m: 1.0,
            radius: 0.5,
        }
        .build()
        .unwrap();
        assert!((o.length() - (2.0 + PI)).abs() < 0.01);
        let r = PathSpec::RoundedRect {
            center: [0.0, 0.0],
            width: 8.0,
            height: 5.0,
            corner_radius: 1.0,
        }
        .build()
        .unwrap();
        assert!((r.length() - (12.0 + 6.0 + TAU)).abs() < 0.01);
        let a = figure_eight_half_width_for_length(4.0);
        let f = PathSpec::FigureEight {
            center: [0.0, 0.0],
            half_width: a,
        }
        .build()
        .unwrap();
        assert!((f.length() - 4.0).abs() < 0.01, "{}", f.length());
    }

    #[test]
    fn start_poses_and_wrapping() {
        let c = PathSpec::Circle {
            center: [0.0, 0.0],
            radius: 5.0,
            start_angle: 0.0,
            ccw: true,
        }
        .build()
        .unwrap();
        let s = c.start_pose();
        assert!((s.x - 5.0).abs() < 1e-9 && (s.theta - FRAC_PI_2).abs() < 0.01);
        let p = c.point_at(c.length() * 1.25);
        assert!((p.x).abs() < 0.01 && (p.y - 5.0).abs() < 0.01);
        let r = PathSpec::RoundedRect {
            center: [0.0, 0.0],
            width: 8.0,
            height: 5.0,
            corner_radius: 1.0,
        }
        .build()
        .unwrap();
        let s = r.start_pose();
        assert!(s.x.abs() < 1e-9 && (s.y + 2.5).abs() < 1e-9 && s.theta.abs() < 1e-9);
    }

    #[test]
    fn closest_search_stays_on_its_branch_at_a_crossing() {
        let a = figure_eight_half_width_for_length(4.0);
        let f = PathSpec::FigureEight {
            center: [0.0, 0.0],
            half_width: a,
        }
        .build()
        .unwrap();
        // At the crossing (the centre) the path passes at s = 0 and s = L/2.
        let near_half = f.closest_near(Vector::ZERO, 0.5 * f.length() - 0.1, 0.3, 0.5);
        assert!((near_half - 0.5 * f.length()).abs() < 0.05);
        let second_lap = f.closest_near(Vector::ZERO, f.length() - 0.05, 0.3, 0.5);
        assert!((second_lap - f.length()).abs() < 0.05);
    }
}
