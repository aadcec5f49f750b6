//! An MCAP of a monocular run (Munguía & Grau §2, the 6-DOF camera of
//! (25)–(30)) that Foxglove opens without extensions: the frames as they
//! were read, the camera's estimated and true paths, and the 3-D map with
//! its uncertainty, frame by frame.
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/camera/image` | `foxglove.CompressedImage` | each frame's image file, its bytes as they are (PNG or JPEG), in frame `camera_estimate` |
//! | `/camera/annotations` | `foxglove.ImageAnnotations` | over the image, as the paper's Fig. 12: each feature's search ellipse (30) clipped to its search box (green: found, red: missed) and a circle where it was found |
//! | `/tf` | `foxglove.FrameTransform` | `world` → `camera_estimate` and, with ground truth, `world` → `camera_truth` |
//! | `/camera/path/estimate`, `/camera/path/truth` | `foxglove.PosesInFrame` | the path so far, every [`PATH_EVERY_FRAMES`] frames and at the last, at most [`PATH_MAX_POSES`] poses (halved past it) |
//! | `/map` | `foxglove.SceneUpdate` | the map after the frame: each landmark its 2σ ellipsoid (blue: a point, orange: still in inverse depth (27)), semi-axes capped at [`MAX_SEMI_AXIS_M`] |
//!
//! The world frame is the sequence's (KITTI: the first camera's, y down);
//! messages are stamped with the frames' times.
//!
//! A path message holds the whole path so far (Foxglove draws a topic's
//! latest message), so republishing it at every frame would make the file
//! grow with the square of the run: KITTI's 4541-frame sequence 00 would
//! carry about 10⁷ poses per path. The paths are therefore thinned as the
//! 2-D log's are ([`crate::McapWriteOptions::path_every`]): republished every
//! [`PATH_EVERY_FRAMES`] frames and at the last frame, each holding at most
//! [`PATH_MAX_POSES`] poses plus the newest; the camera's own pose is on
//! `/tf` at every frame.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use bearing_slam_core::mono::{CameraPose, MapPoint};
use bearing_slam_core::nalgebra::{Matrix3, Rotation3, UnitQuaternion};
use mcap::records::MessageHeader;
use serde::Serialize;
use serde_json::Value;

use crate::error::{IoError, Result};
use crate::foxglove::{
    self as fx, Color, FrameTransform, Pose, PosesInFrame, Quaternion, SceneEntity,
    SceneEntityDeletion, SceneUpdate, SpherePrimitive, Time, Vector3,
};
use crate::foxglove_image::{
    self as fi, CircleAnnotation, CompressedImage, ImageAnnotations, Point2, PointsAnnotation,
};
use crate::path_view::{PathCadence, PathView};
use crate::schema::declare_json_channel;
use bearing_slam_core::nalgebra::{Matrix2, Vector2};

/// The child frame of the estimated camera on `/tf`.
pub const CAMERA_ESTIMATE_FRAME: &str = "camera_estimate";
/// The child frame of the true camera on `/tf`.
pub const CAMERA_TRUTH_FRAME: &str = "camera_truth";
/// The largest semi-axis drawn, metres: a landmark whose depth is still
/// unknown has a covariance reaching far along its ray, which would fill
/// the view.
pub const MAX_SEMI_AXIS_M: f64 = 10.0;
/// The paths are republished every this many frames (1 s of KITTI's 10 Hz
/// camera), and at the last frame.
pub const PATH_EVERY_FRAMES: usize = 10;
/// Most poses a published path keeps before it is halved (the 2-D log's
/// default, [`crate::McapWriteOptions::path_max_points`]).
pub const PATH_MAX_POSES: usize = 1000;

/// One frame of a monocular run, as the viewer shows it.
#[derive(Clone, Copy, Debug)]
pub struct MonoFrameView<'a> {
    /// The frame's time, seconds (non-negative, increasing).
    pub time_s: f64,
    /// The image file (`.png`, `.jpg` or `.jpeg`), written as it is.
    pub image: &'a Path,
    /// The filter's camera pose after the frame.
    pub estimate: CameraPose,
    /// The true camera pose, if known.
    pub truth: Option<CameraPose>,
    /// The map after the frame.
    pub map: &'a [MapPoint],
    /// The frame's searches, drawn over its image.
    pub searches: &'a [SearchMark],
}

/// One feature's active search in a frame, as Fig. 12 draws it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchMark {
    /// The predicted pixel (pixel centres at integers).
    pub predicted_px: Vector2<f64>,
    /// The search ellipse `νᵀ E⁻¹ ν ≤ 1`: `E = χ² S_i` for the innovation
    /// covariance `S_i` (30) at the search's χ² level, pixels².
    pub ellipse: Matrix2<f64>,
    /// The half side of the box the search is clipped to, pixels (the
    /// front end's `max_half_axis_px`): the ellipse is drawn clipped to it,
    /// as it was searched.
    pub clip_half_px: f64,
    /// Where the feature was found, if it was.
    pub found_px: Option<Vector2<f64>>,
}

/// Points on each search ellipse drawn.
const ELLIPSE_POINTS: usize = 24;

/// A topic of the file: its name and its message's schema.
#[derive(Clone, Copy)]
struct Topic {
    name: &'static str,
    schema_name: &'static str,
    schema: fn() -> Value,
}

const IMAGE: Topic = Topic {
    name: "/camera/image",
    schema_name: fi::COMPRESSED_IMAGE,
    schema: fi::compressed_image_schema,
};
const ANNOTATIONS: Topic = Topic {
    name: "/camera/annotations",
    schema_name: fi::IMAGE_ANNOTATIONS,
    schema: fi::image_annotations_schema,
};
const TF: Topic = Topic {
    name: "/tf",
    schema_name: fx::FRAME_TRANSFORM,
    schema: fx::frame_transform_schema,
};
const PATH_ESTIMATE: Topic = Topic {
    name: "/camera/path/estimate",
    schema_name: fx::POSES_IN_FRAME,
    schema: fx::poses_in_frame_schema,
};
const PATH_TRUTH: Topic = Topic {
    name: "/camera/path/truth",
    ..PATH_ESTIMATE
};
const MAP: Topic = Topic {
    name: "/map",
    schema_name: fx::SCENE_UPDATE,
    schema: fx::scene_update_schema,
};

/// Writes `frames` to a new MCAP file at `path` (zstd chunks). Errors name
/// the file and the frame: a time that is negative, not finite or not
/// increasing, a pose or landmark that is not finite, an image that cannot
/// be read or is neither PNG nor JPEG. The file is written to
/// `path` + `.partial` and renamed when complete, so a failed run leaves
/// no half-written file under `path` (and an earlier file there stays).
pub fn write_mono_mcap(path: impl AsRef<Path>, frames: &[MonoFrameView<'_>]) -> Result<()> {
    let path = path.as_ref().to_path_buf();
    let mut partial = path.clone().into_os_string();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let written = write_frames(&partial, &path, frames);
    if written.is_err() {
        // The partial file is useless; its removal failing changes nothing.
        let _ = std::fs::remove_file(&partial);
        return written;
    }
    std::fs::rename(&partial, &path).map_err(|source| IoError::Io {
        path: path.clone(),
        action: "rename the finished file to",
        source,
    })
}

fn write_frames(partial: &Path, path: &Path, frames: &[MonoFrameView<'_>]) -> Result<()> {
    let file = File::create(partial).map_err(|source| IoError::Io {
        path: partial.to_path_buf(),
        action: "create",
        source,
    })?;
    let writer = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .profile("")
        .library(format!("bearing-slam-io {}", env!("CARGO_PKG_VERSION")))
        .create(BufWriter::new(file))
        .map_err(|source| mcap_error(path, "writing the file header", source))?;
    let mut out = MonoWriter {
        path: path.to_path_buf(),
        writer,
        channels: BTreeMap::new(),
        sequence: 0,
    };
    let mut estimates = PathView::new();
    let mut truths = PathView::new();
    let cadence = PathCadence::EveryPoses(PATH_EVERY_FRAMES);
    let mut last_time = None;
    for (index, frame) in frames.iter().enumerate() {
        let bad = |field: String, value: f64| IoError::NonFinite {
            path: path.to_path_buf(),
            topic: format!("frame {index}"),
            field,
            value,
        };
        if !(frame.time_s.is_finite() && frame.time_s >= 0.0)
            || last_time.is_some_and(|t| frame.time_s <= t)
        {
            return Err(IoError::TimeOutOfRange {
                path: path.to_path_buf(),
                topic: format!("frame {index} (times must be non-negative and increase)"),
                time: frame.time_s,
            });
        }
        last_time = Some(frame.time_s);
        // Nanoseconds of a time below 2^32 s fit a u64.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let log_time = (frame.time_s * 1e9).round() as u64;
        let stamp = Time::from_nanos(log_time).ok_or_else(|| IoError::TimeOutOfRange {
            path: path.to_path_buf(),
            topic: format!("frame {index}"),
            time: frame.time_s,
        })?;
        if let Some(v) = first_non_finite(pose_values(&frame.estimate)) {
            return Err(bad("estimate".into(), v));
        }
        if let Some(v) = frame
            .truth
            .as_ref()
            .and_then(|t| first_non_finite(pose_values(t)))
        {
            return Err(bad("truth".into(), v));
        }
        for point in frame.map {
            let values = point
                .position
                .iter()
                .chain(point.covariance.iter())
                .copied();
            if let Some(v) = first_non_finite(values) {
                return Err(bad(format!("landmark {}", point.feature_id), v));
            }
        }
        for (i, mark) in frame.searches.iter().enumerate() {
            let found = mark.found_px.iter().flat_map(|p| p.iter().copied());
            let values = mark.predicted_px.iter().chain(mark.ellipse.iter()).copied();
            let clip = std::iter::once(mark.clip_half_px);
            if let Some(v) = first_non_finite(values.chain(found).chain(clip)) {
                return Err(bad(format!("search {i}"), v));
            }
        }
        let estimate = pose_of(&frame.estimate);
        let truth = frame.truth.as_ref().map(pose_of);
        out.image(log_time, stamp, frame.image)?;
        out.emit(ANNOTATIONS, log_time, &annotations(stamp, frame.searches))?;
        let last = index + 1 == frames.len();
        out.transform(log_time, stamp, CAMERA_ESTIMATE_FRAME, estimate)?;
        if estimates.push(estimate, cadence, PATH_MAX_POSES) || last {
            out.path(PATH_ESTIMATE, log_time, stamp, &mut estimates)?;
        }
        if let Some(truth) = truth {
            out.transform(log_time, stamp, CAMERA_TRUTH_FRAME, truth)?;
            if truths.push(truth, cadence, PATH_MAX_POSES) || last {
                out.path(PATH_TRUTH, log_time, stamp, &mut truths)?;
            }
        }
        out.emit(MAP, log_time, &map_scene(stamp, frame.map))?;
    }
    out.writer
        .finish()
        .map_err(|source| mcap_error(path, "finishing the file", source))?;
    Ok(())
}

/// The first value that is NaN or infinite.
fn first_non_finite(mut values: impl Iterator<Item = f64>) -> Option<f64> {
    values.find(|v| !v.is_finite())
}

fn mcap_error(path: &Path, action: &str, source: mcap::McapError) -> IoError {
    IoError::Mcap {
        path: path.to_path_buf(),
        action: action.to_owned(),
        source,
    }
}

struct MonoWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: BTreeMap<&'static str, u16>,
    sequence: u32,
}

impl MonoWriter {
    fn channel(&mut self, topic: Topic) -> Result<u16> {
        if let Some(&id) = self.channels.get(topic.name) {
            return Ok(id);
        }
        let id = declare_json_channel(
            &mut self.writer,
            &self.path,
            topic.name,
            (topic.schema_name, &(topic.schema)()),
            &BTreeMap::new(),
        )?;
        self.channels.insert(topic.name, id);
        Ok(id)
    }

    fn emit<T: Serialize + ?Sized>(
        &mut self,
        topic: Topic,
        log_time: u64,
        value: &T,
    ) -> Result<()> {
        let data = serde_json::to_vec(value).map_err(|source| IoError::Encode {
            path: self.path.clone(),
            topic: topic.name.into(),
            source,
        })?;
        let header = MessageHeader {
            channel_id: self.channel(topic)?,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        self.writer
            .write_to_known_channel(&header, &data)
            .map_err(|source| {
                mcap_error(
                    &self.path,
                    &format!("writing a message on {}", topic.name),
                    source,
                )
            })?;
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    fn image(&mut self, log_time: u64, stamp: Time, image: &Path) -> Result<()> {
        use base64::Engine as _;
        let format = match image
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => "png",
            Some("jpg" | "jpeg") => "jpeg",
            _ => {
                return Err(IoError::Image {
                    path: image.to_path_buf(),
                    reason: "not a .png, .jpg or .jpeg file".into(),
                });
            }
        };
        let bytes = std::fs::read(image).map_err(|source| IoError::Io {
            path: image.to_path_buf(),
            action: "read",
            source,
        })?;
        let message = CompressedImage {
            timestamp: stamp,
            frame_id: CAMERA_ESTIMATE_FRAME,
            data: base64::engine::general_purpose::STANDARD.encode(bytes),
            format,
        };
        self.emit(IMAGE, log_time, &message)
    }

    fn transform(
        &mut self,
        log_time: u64,
        stamp: Time,
        child: &'static str,
        pose: Pose,
    ) -> Result<()> {
        self.emit(
            TF,
            log_time,
            &FrameTransform {
                timestamp: stamp,
                parent_frame_id: fx::WORLD_FRAME,
                child_frame_id: child,
                translation: pose.position,
                rotation: pose.orientation,
            },
        )
    }

    /// Publishes `path` on `topic` (`/camera/path/estimate` or `/truth`).
    fn path(
        &mut self,
        topic: Topic,
        log_time: u64,
        stamp: Time,
        path: &mut PathView,
    ) -> Result<()> {
        let poses = path.publish();
        self.emit(
            topic,
            log_time,
            &PosesInFrame {
                timestamp: stamp,
                frame_id: fx::WORLD_FRAME,
                poses: &poses,
            },
        )
    }
}

/// A camera pose's position and quaternion `(x, y, z, w)`.
fn pose_values(pose: &CameraPose) -> impl Iterator<Item = f64> {
    let q = pose.orientation.quaternion();
    [
        pose.position.x,
        pose.position.y,
        pose.position.z,
        q.i,
        q.j,
        q.k,
        q.w,
    ]
    .into_iter()
}

/// A camera pose as a Foxglove pose.
fn pose_of(pose: &CameraPose) -> Pose {
    let q = pose.orientation.quaternion();
    Pose {
        position: Vector3 {
            x: pose.position.x,
            y: pose.position.y,
            z: pose.position.z,
        },
        orientation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

/// The searches over the image: each ellipse a closed polyline (its points
/// clamped to the search's box), each match a circle (Foxglove's pixel
/// origin is the top-left pixel's corner, ours its centre: half a pixel
/// apart).
fn annotations(stamp: Time, searches: &[SearchMark]) -> ImageAnnotations {
    let found = Color::rgba(0.2, 0.9, 0.2, 1.0);
    let missed = Color::rgba(1.0, 0.25, 0.2, 1.0);
    let clear = Color::rgba(0.0, 0.0, 0.0, 0.0);
    let corner = |p: Vector2<f64>| Point2 {
        x: p.x + 0.5,
        y: p.y + 0.5,
    };
    let points = searches
        .iter()
        .map(|mark| {
            let c = 0.5 * (mark.ellipse + mark.ellipse.transpose());
            let eigen = c.symmetric_eigen();
            let axes = eigen.eigenvectors
                * Matrix2::from_diagonal(&eigen.eigenvalues.map(|l| l.max(0.0).sqrt()));
            let ring = (0..ELLIPSE_POINTS)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / ELLIPSE_POINTS as f64;
                    let offset = (axes * Vector2::new(t.cos(), t.sin()))
                        .map(|d| d.clamp(-mark.clip_half_px, mark.clip_half_px));
                    corner(mark.predicted_px + offset)
                })
                .collect();
            PointsAnnotation {
                timestamp: stamp,
                kind: fi::points_type::LINE_LOOP,
                points: ring,
                outline_color: if mark.found_px.is_some() {
                    found
                } else {
                    missed
                },
                outline_colors: Vec::new(),
                fill_color: clear,
                thickness: 1.0,
            }
        })
        .collect();
    let circles = searches
        .iter()
        .filter_map(|mark| mark.found_px)
        .map(|px| CircleAnnotation {
            timestamp: stamp,
            position: corner(px),
            diameter: 5.0,
            thickness: 1.5,
            fill_color: clear,
            outline_color: found,
        })
        .collect();
    ImageAnnotations {
        circles,
        points,
        texts: Vec::new(),
    }
}

/// The map as one entity of ellipsoids (replacing the previous frame's).
fn map_scene(stamp: Time, map: &[MapPoint]) -> SceneUpdate {
    let mut entity = SceneEntity::new(stamp, fx::WORLD_FRAME, "map".into());
    entity.spheres = map.iter().map(ellipsoid).collect();
    SceneUpdate {
        deletions: vec![SceneEntityDeletion::all(stamp)],
        entities: vec![entity],
    }
}

/// The 2σ ellipsoid of a landmark: a sphere primitive scaled to the
/// diameters `4√λ` along the covariance's eigenvectors (its orientation),
/// each semi-axis at most [`MAX_SEMI_AXIS_M`].
fn ellipsoid(point: &MapPoint) -> SpherePrimitive {
    let c = 0.5 * (point.covariance + point.covariance.transpose());
    let eigen = c.symmetric_eigen();
    let mut axes: Matrix3<f64> = eigen.eigenvectors;
    if axes.determinant() < 0.0 {
        axes.column_mut(2).neg_mut();
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(axes));
    let diameter = |l: f64| 2.0 * (2.0 * l.max(0.0).sqrt()).min(MAX_SEMI_AXIS_M);
    let color = if point.inverse_depth {
        Color::rgba(1.0, 0.55, 0.1, 0.6)
    } else {
        Color::rgba(0.2, 0.45, 1.0, 0.6)
    };
    SpherePrimitive {
        pose: Pose {
            position: Vector3 {
                x: point.position.x,
                y: point.position.y,
                z: point.position.z,
            },
            orientation: Quaternion {
                x: rotation.i,
                y: rotation.j,
                z: rotation.k,
                w: rotation.w,
            },
        },
        size: Vector3 {
            x: diameter(eigen.eigenvalues[0]),
            y: diameter(eigen.eigenvalues[1]),
            z: diameter(eigen.eigenvalues[2]),
        },
        color,
    }
}
