//! The frames source: a directory in the layout of the KITTI odometry clips
//! (`image_l/NNNNNN.png`, `calib.txt` with the projection matrix `P0`,
//! `poses.txt` with one 3×4 camera-to-world pose per frame, optional
//! `times.txt`, `known_points.txt`: the paper's metric reference, one
//! `x y z` world point per line, and `speeds.txt`: speed readings, m/s, as
//! a car's wheel odometry gives, one per frame or `time speed` at the
//! sensor's own rate ([`crate::speeds`])). The synthetic renderer ([`crate::render`]) writes the same
//! layout, so one loader reads both.

use crate::error::{Result, VisionError};
use bearing_slam_core::mono::CameraPose;
use image::GrayImage;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The pinhole intrinsics of an undistorted (rectified) camera, pixels.
///
/// Pixel centres are at integer coordinates: the point `(x, y, z)` of the
/// camera frame (x right, y down, z forward) is seen at
/// `(fx x/z + cx, fy y/z + cy)` (Munguía & Grau (29) without distortion).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
}

impl Intrinsics {
    /// The pixel of a point in the camera frame; `None` behind the camera.
    pub fn project(&self, p_camera: &Vector3<f64>) -> Option<Vector2<f64>> {
        if p_camera.z <= 1e-9 {
            return None;
        }
        Some(Vector2::new(
            self.fx * p_camera.x / p_camera.z + self.cx,
            self.fy * p_camera.y / p_camera.z + self.cy,
        ))
    }

    /// The ray through a pixel in the camera frame, with unit depth (z = 1).
    pub fn ray(&self, px: &Vector2<f64>) -> Vector3<f64> {
        Vector3::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy, 1.0)
    }
}

/// The pixel at which a world point is seen from `pose` (world_from_camera).
pub fn project_world(
    intrinsics: &Intrinsics,
    pose: &CameraPose,
    p_world: &Vector3<f64>,
) -> Option<Vector2<f64>> {
    let p_camera = pose
        .orientation
        .inverse_transform_vector(&(p_world - pose.position));
    intrinsics.project(&p_camera)
}

/// A sequence of frames on disk with its calibration and ground truth.
#[derive(Clone, Debug)]
pub struct FrameSequence {
    /// The directory.
    pub dir: PathBuf,
    /// The camera intrinsics (from `P0` of calib.txt).
    pub intrinsics: Intrinsics,
    /// Image width, pixels (all frames agree; checked when loaded).
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The ground-truth camera-to-world pose of every frame.
    pub poses: Vec<CameraPose>,
    /// The time of every frame, seconds (times.txt, or frame index × 0.1 s,
    /// the 10 Hz of KITTI, when the file is absent).
    pub times: Vec<f64>,
    /// The image files, in frame order.
    pub images: Vec<PathBuf>,
    /// The metric reference's known world points (`known_points.txt`;
    /// empty when the directory has none).
    pub known_points: Vec<Vector3<f64>>,
    /// The speed over the interval ending at each frame, m/s (`speeds.txt`,
    /// one per frame or timestamped at the sensor's rate and resampled:
    /// [`crate::speeds`]; frame 0's is not used), if the directory has them.
    pub speeds: Option<Vec<f64>>,
}

/// The optional file of speed readings, one per frame (m/s).
pub const SPEEDS_FILE: &str = "speeds.txt";

/// The optional file of known world points (the metric reference).
pub const KNOWN_POINTS_FILE: &str = "known_points.txt";

/// The frame period assumed when a directory has no times.txt (KITTI: 10 Hz).
pub const DEFAULT_FRAME_PERIOD_S: f64 = 0.1;

impl FrameSequence {
    /// Opens a frames directory: reads calib.txt (or `calib` when given),
    /// poses.txt, times.txt if present, lists image_l/*.png and checks that
    /// the counts agree, the names are `000000.png` … in order, and the first
    /// image decodes.
    pub fn open(dir: impl AsRef<Path>, calib: Option<&Path>) -> Result<Self> {
        let dir = dir.as_ref().to_path_buf();
        if !dir.is_dir() {
            return Err(VisionError::Layout {
                dir,
                reason: "not a directory".into(),
            });
        }
        let calib_path = calib.map_or_else(|| dir.join("calib.txt"), Path::to_path_buf);
        let intrinsics = read_calibration(&calib_path)?;
        let poses = read_poses(&dir.join("poses.txt"))?;
        let images = list_images(&dir)?;
        if images.len() != poses.len() {
            return Err(VisionError::Layout {
                dir,
                reason: format!(
                    "image_l has {} PNG frames but poses.txt has {} poses",
                    images.len(),
                    poses.len()
                ),
            });
        }
        let times_path = dir.join("times.txt");
        let times = if times_path.exists() {
            let times = read_times(&times_path)?;
            if times.len() != images.len() {
                return Err(VisionError::Layout {
                    dir,
                    reason: format!(
                        "times.txt has {} lines but image_l has {} frames",
                        times.len(),
                        images.len()
                    ),
                });
            }
            times
        } else {
            (0..images.len())
                .map(|k| k as f64 * DEFAULT_FRAME_PERIOD_S)
                .collect()
        };
        let known_path = dir.join(KNOWN_POINTS_FILE);
        let known_points = if known_path.exists() {
            read_known_points(&known_path)?
        } else {
            Vec::new()
        };
        let speeds_path = dir.join(SPEEDS_FILE);
        let speeds = if speeds_path.exists() {
            Some(crate::speeds::read_speeds(&speeds_path, &times)?)
        } else {
            None
        };
        let first = load_gray(&images[0])?;
        Ok(Self {
            dir,
            intrinsics,
            width: first.width(),
            height: first.height(),
            poses,
            times,
            images,
            known_points,
            speeds,
        })
    }

    /// The number of frames.
    pub fn len(&self) -> usize {
        self.images.len()
    }

    /// Whether the sequence has no frame (never true for an opened one).
    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }

    /// Decodes frame `index` as 8-bit gray; its size must match the first's.
    pub fn frame(&self, index: usize) -> Result<GrayImage> {
        let path = self.images.get(index).ok_or_else(|| VisionError::Layout {
            dir: self.dir.clone(),
            reason: format!("frame {index} out of range (0..{})", self.images.len()),
        })?;
        let image = load_gray(path)?;
        if image.dimensions() != (self.width, self.height) {
            return Err(VisionError::Image {
                path: path.clone(),
                message: format!(
                    "size {}×{} differs from the first frame's {}×{}",
                    image.width(),
                    image.height(),
                    self.width,
                    self.height
                ),
            });
        }
        Ok(image)
    }
}

/// Decodes a PNG (or any format the `image` build supports) to 8-bit gray.
pub fn load_gray(path: &Path) -> Result<GrayImage> {
    let reader = image::ImageReader::open(path).map_err(|e| VisionError::io(path, e))?;
    let decoded = reader
        .with_guessed_format()
        .map_err(|e| VisionError::io(path, e))?
        .decode()
        .map_err(|e| VisionError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    Ok(decoded.into_luma8())
}

pub(crate) fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| VisionError::io(path, e))
}

fn parse_numbers(path: &Path, line_no: usize, line: &str, count: usize) -> Result<Vec<f64>> {
    let parse_error = |reason: String| VisionError::Parse {
        path: path.to_path_buf(),
        line: line_no,
        reason,
    };
    let mut fields = line.split_whitespace();
    // calib.txt of the KITTI odometry set prefixes each matrix with "P0:".
    let mut values = Vec::with_capacity(count);
    for field in fields.by_ref() {
        if values.is_empty() && field.ends_with(':') {
            continue;
        }
        let value: f64 = field
            .parse()
            .map_err(|_| parse_error(format!("{field:?} is not a number")))?;
        if !value.is_finite() {
            return Err(parse_error(format!("{field:?} is not finite")));
        }
        values.push(value);
    }
    if values.len() != count {
        return Err(parse_error(format!(
            "expected {count} numbers, found {}",
            values.len()
        )));
    }
    Ok(values)
}

/// Reads the intrinsics from the first line (`P0`) of a KITTI calib.txt:
/// `fx = P[0], cx = P[2], fy = P[5], cy = P[6]`.
pub fn read_calibration(path: &Path) -> Result<Intrinsics> {
    let text = read_text(path)?;
    let (line_no, line) = text
        .lines()
        .enumerate()
        .find(|(_, l)| !l.trim().is_empty())
        .ok_or_else(|| VisionError::Parse {
            path: path.to_path_buf(),
            line: 1,
            reason: "empty file: expected the 3×4 matrix P0 (12 numbers)".into(),
        })?;
    let p = parse_numbers(path, line_no + 1, line, 12)?;
    if p[0] <= 0.0 || p[5] <= 0.0 {
        return Err(VisionError::Parse {
            path: path.to_path_buf(),
            line: line_no + 1,
            reason: format!(
                "focal lengths fx = {}, fy = {} must be positive",
                p[0], p[5]
            ),
        });
    }
    Ok(Intrinsics {
        fx: p[0],
        fy: p[5],
        cx: p[2],
        cy: p[6],
    })
}

/// The non-blank lines of a text file of numbers, each with its 1-based
/// line number and exactly `count` finite numbers ([`parse_numbers`]).
pub(crate) fn numeric_rows(path: &Path, count: usize) -> Result<Vec<(usize, Vec<f64>)>> {
    let text = read_text(path)?;
    text.lines()
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty())
        .map(|(i, line)| Ok((i + 1, parse_numbers(path, i + 1, line, count)?)))
        .collect()
}

/// Reads poses.txt: one camera-to-world `[R | t]` per line, 12 numbers row-major.
/// The rotation is projected to the nearest rotation matrix; one that is far
/// from orthonormal is an error.
pub fn read_poses(path: &Path) -> Result<Vec<CameraPose>> {
    let mut poses = Vec::new();
    for (line, v) in numeric_rows(path, 12)? {
        let m = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
        let orthonormality = (m.transpose() * m - Matrix3::identity()).norm();
        if orthonormality > 1e-3 || m.determinant() <= 0.0 {
            return Err(VisionError::Parse {
                path: path.to_path_buf(),
                line,
                reason: format!(
                    "the 3×3 block is not a rotation (‖RᵀR − I‖ = {orthonormality:.3e}, det = {:.3})",
                    m.determinant()
                ),
            });
        }
        let rotation = Rotation3::from_matrix_eps(&m, 1e-12, 100, Rotation3::identity());
        poses.push(CameraPose {
            position: Vector3::new(v[3], v[7], v[11]),
            orientation: UnitQuaternion::from_rotation_matrix(&rotation),
        });
    }
    if poses.is_empty() {
        return Err(VisionError::Parse {
            path: path.to_path_buf(),
            line: 1,
            reason: "no pose: expected one line of 12 numbers per frame".into(),
        });
    }
    Ok(poses)
}

/// `x y z` per line (blank lines skipped); at least one point.
fn read_known_points(path: &Path) -> Result<Vec<Vector3<f64>>> {
    let points: Vec<Vector3<f64>> = numeric_rows(path, 3)?
        .into_iter()
        .map(|(_, v)| Vector3::new(v[0], v[1], v[2]))
        .collect();
    if points.is_empty() {
        return Err(VisionError::Parse {
            path: path.to_path_buf(),
            line: 1,
            reason: "no point: expected one line of 3 numbers (x y z) per known point".into(),
        });
    }
    Ok(points)
}

/// One speed per line, m/s, never negative.
fn read_times(path: &Path) -> Result<Vec<f64>> {
    let mut times: Vec<f64> = Vec::new();
    for (line, v) in numeric_rows(path, 1)? {
        let t = v[0];
        if times.last().is_some_and(|&last| t <= last) {
            return Err(VisionError::Parse {
                path: path.to_path_buf(),
                line,
                reason: format!("time {t} does not increase"),
            });
        }
        times.push(t);
    }
    Ok(times)
}

/// Lists `image_l/*.png` in order and checks the names run `000000.png`,
/// `000001.png`, … without a gap.
fn list_images(dir: &Path) -> Result<Vec<PathBuf>> {
    let image_dir = dir.join("image_l");
    let entries = std::fs::read_dir(&image_dir).map_err(|e| VisionError::io(&image_dir, e))?;
    let mut images = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| VisionError::io(&image_dir, e))?.path();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            images.push(path);
        }
    }
    images.sort();
    if images.is_empty() {
        return Err(VisionError::Layout {
            dir: dir.to_path_buf(),
            reason: "image_l holds no PNG frame".into(),
        });
    }
    for (k, path) in images.iter().enumerate() {
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if stem.parse::<usize>().ok() != Some(k) {
            return Err(VisionError::Layout {
                dir: dir.to_path_buf(),
                reason: format!(
                    "frame {k} should be image_l/{k:06}.png, found {} (a gap or a stray file)",
                    path.display()
                ),
            });
        }
    }
    Ok(images)
}
