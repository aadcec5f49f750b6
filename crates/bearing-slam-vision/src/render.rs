//! The synthetic sequence: [`Scene::room`] seen along [`CameraPath`],
//! ray-cast per pixel (2×2 supersampling) into 8-bit gray frames, written in
//! the layout of the KITTI clips (`image_l/NNNNNN.png`, `calib.txt`,
//! `poses.txt`, plus `times.txt`, `scene.json` and, with the reference
//! sheet, `known_points.txt`) so that
//! [`crate::frames::FrameSequence::open`] reads it like the real video.

use crate::error::{Result, VisionError};
use crate::frames::{FrameSequence, Intrinsics, KNOWN_POINTS_FILE};
use crate::scene::{CameraPath, Scene};
use bearing_slam_core::mono::CameraPose;
use image::GrayImage;
use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// What to render: image size, field of view, length, rate and texture seed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SyntheticConfig {
    /// Image width, pixels (the paper's camera: 424).
    pub width: u32,
    /// Image height, pixels (the paper's camera: 240).
    pub height: u32,
    /// Horizontal field of view, degrees.
    pub hfov_deg: f64,
    /// Number of frames.
    pub frames: usize,
    /// Frame rate, Hz (the paper's camera: 30).
    pub fps: f64,
    /// The textures' seed.
    pub seed: u64,
    /// The camera's path.
    pub path: CameraPath,
    /// Hang the paper's metric reference in the room
    /// ([`Scene::with_reference_sheet`]) and write its four corners to
    /// `known_points.txt`.
    pub reference_sheet: bool,
}

impl Default for SyntheticConfig {
    fn default() -> Self {
        Self {
            width: 424,
            height: 240,
            hfov_deg: 70.0,
            frames: 150,
            fps: 30.0,
            seed: 1,
            path: CameraPath::default(),
            reference_sheet: false,
        }
    }
}

impl SyntheticConfig {
    /// Checks the sizes, field of view, length and rate.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value: f64, reason| {
            Err(VisionError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(8..=8192).contains(&self.width) {
            return bad("width", self.width.into(), "must be 8–8192 pixels");
        }
        if !(8..=8192).contains(&self.height) {
            return bad("height", self.height.into(), "must be 8–8192 pixels");
        }
        if !(self.hfov_deg > 1.0 && self.hfov_deg < 170.0) {
            return bad("hfov_deg", self.hfov_deg, "must be in (1, 170) degrees");
        }
        if self.frames < 2 {
            return bad("frames", self.frames as f64, "at least 2 frames");
        }
        if !(self.fps.is_finite() && self.fps > 0.0) {
            return bad("fps", self.fps, "must be positive and finite");
        }
        Ok(())
    }

    /// The pinhole intrinsics: square pixels, principal point at the centre.
    pub fn intrinsics(&self) -> Intrinsics {
        let f = 0.5 * f64::from(self.width) / (0.5 * self.hfov_deg.to_radians()).tan();
        Intrinsics {
            fx: f,
            fy: f,
            cx: 0.5 * f64::from(self.width - 1),
            cy: 0.5 * f64::from(self.height - 1),
        }
    }

    /// The scene.
    pub fn scene(&self) -> Scene {
        self.scene_and_known_points().0
    }

    /// The scene and its known points (the reference sheet's corners; none
    /// without the sheet).
    pub fn scene_and_known_points(&self) -> (Scene, Vec<Vector3<f64>>) {
        let room = Scene::room(self.seed);
        if self.reference_sheet {
            let (scene, corners) = room.with_reference_sheet();
            (scene, corners.to_vec())
        } else {
            (room, Vec::new())
        }
    }

    /// The time of frame `k`, seconds.
    pub fn time(&self, k: usize) -> f64 {
        k as f64 / self.fps
    }

    /// The ground-truth pose of frame `k`.
    pub fn pose(&self, k: usize) -> CameraPose {
        self.path.pose(self.time(k))
    }
}

/// Renders one frame: each pixel the mean of 2×2 rays (offsets ±¼ pixel
/// around the pixel centre, which sits at integer coordinates).
pub fn render_frame(
    scene: &Scene,
    intrinsics: &Intrinsics,
    pose: &CameraPose,
    width: u32,
    height: u32,
) -> GrayImage {
    const OFFSETS: [(f64, f64); 4] = [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)];
    let rotation = pose.orientation.to_rotation_matrix();
    let mut image = GrayImage::new(width, height);
    for (u, v, pixel) in image.enumerate_pixels_mut() {
        let mut sum = 0.0;
        for (du, dv) in OFFSETS {
            let ray_camera = intrinsics.ray(&Vector2::new(f64::from(u) + du, f64::from(v) + dv));
            let ray_world = rotation * ray_camera;
            sum += scene
                .cast(&pose.position, &ray_world)
                .map_or(scene.background, |hit| hit.grey);
        }
        pixel.0[0] = (sum / 4.0).round().clamp(0.0, 255.0) as u8;
    }
    image
}

/// The world point seen at pixel `px` from `pose`, if any (the oracle's depth).
pub fn point_at_pixel(
    scene: &Scene,
    intrinsics: &Intrinsics,
    pose: &CameraPose,
    px: &Vector2<f64>,
) -> Option<Vector3<f64>> {
    let ray_world = pose.orientation * intrinsics.ray(px);
    scene.cast(&pose.position, &ray_world).map(|hit| hit.point)
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    let mut file = std::fs::File::create(path).map_err(|e| VisionError::io(path, e))?;
    file.write_all(text.as_bytes())
        .map_err(|e| VisionError::io(path, e))
}

/// One pose as the 12 numbers of a KITTI poses.txt line.
fn pose_line(pose: &CameraPose) -> String {
    let r = pose.orientation.to_rotation_matrix();
    let m = r.matrix();
    let t = pose.position;
    let mut fields = Vec::with_capacity(12);
    for i in 0..3 {
        for j in 0..3 {
            fields.push(format!("{:.12e}", m[(i, j)]));
        }
        fields.push(format!("{:.12e}", t[i]));
    }
    fields.join(" ")
}

/// Renders the sequence into `dir` (created if needed) in the KITTI clip
/// layout and returns it opened. `scene.json` records the config so the
/// ground-truth oracle can rebuild the scene.
pub fn render_sequence(config: &SyntheticConfig, dir: &Path) -> Result<FrameSequence> {
    config.validate()?;
    let image_dir = dir.join("image_l");
    std::fs::create_dir_all(&image_dir).map_err(|e| VisionError::io(&image_dir, e))?;
    let intrinsics = config.intrinsics();
    let (scene, known_points) = config.scene_and_known_points();
    if !known_points.is_empty() {
        let lines: String = known_points
            .iter()
            .map(|p| format!("{:.12e} {:.12e} {:.12e}\n", p.x, p.y, p.z))
            .collect();
        write_text(&dir.join(KNOWN_POINTS_FILE), &lines)?;
    }
    let (fx, fy, cx, cy) = (intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy);
    let p0 = format!("{fx:.12e} 0 {cx:.12e} 0 0 {fy:.12e} {cy:.12e} 0 0 0 1 0");
    write_text(&dir.join("calib.txt"), &format!("{p0}\n{p0}\n"))?;
    let mut poses = String::new();
    let mut times = String::new();
    for k in 0..config.frames {
        let pose = config.pose(k);
        poses.push_str(&pose_line(&pose));
        poses.push('\n');
        times.push_str(&format!("{:.9e}\n", config.time(k)));
        let image = render_frame(&scene, &intrinsics, &pose, config.width, config.height);
        let path = image_dir.join(format!("{k:06}.png"));
        image.save(&path).map_err(|e| VisionError::Image {
            path: path.clone(),
            message: e.to_string(),
        })?;
    }
    write_text(&dir.join("poses.txt"), &poses)?;
    write_text(&dir.join("times.txt"), &times)?;
    let json = serde_json::to_string_pretty(config).map_err(|e| VisionError::Layout {
        dir: dir.to_path_buf(),
        reason: format!("scene.json: {e}"),
    })?;
    write_text(&dir.join(SCENE_FILE), &json)?;
    FrameSequence::open(dir, None)
}

/// The file in which [`render_sequence`] records its [`SyntheticConfig`].
pub const SCENE_FILE: &str = "scene.json";

/// Reads the [`SyntheticConfig`] of a rendered directory (`None` for real
/// video, which has no scene.json).
pub fn read_scene_config(dir: &Path) -> Result<Option<SyntheticConfig>> {
    let path = dir.join(SCENE_FILE);
    if !path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|e| VisionError::io(&path, e))?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| VisionError::Parse {
            path,
            line: e.line(),
            reason: e.to_string(),
        })
}
