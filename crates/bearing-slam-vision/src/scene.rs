//! A synthetic 3-D scene with exact geometry: textured rectangles (walls,
//! floor, the faces of boxes) with a procedural texture full of corners, and
//! a smooth 6-DOF camera path. The renderer ([`crate::render`]) ray-casts it;
//! the ground-truth oracle ([`crate::oracle`]) casts the same rays to know
//! the depth of every feature.

use bearing_slam_core::mono::CameraPose;
use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// What is painted on a [`TexturedQuad`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Pattern {
    /// [`TexturedQuad::texture`]'s random grey cells and blobs.
    #[default]
    Cells,
    /// The paper's metric reference: a white sheet with a black rectangle
    /// [`REFERENCE_MARGIN_M`] in from every edge, whose four corners are the
    /// known points ([`Scene::with_reference_sheet`]).
    ReferenceSheet,
}

/// A textured rectangle `{origin + s·edge_u + t·edge_v : s, t ∈ [0, 1]}`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexturedQuad {
    /// One corner, world frame (metres).
    pub origin: Vector3<f64>,
    /// The first edge from `origin`.
    pub edge_u: Vector3<f64>,
    /// The second edge from `origin` (orthogonal to `edge_u`).
    pub edge_v: Vector3<f64>,
    /// The texture's seed (each face looks different).
    pub texture_seed: u64,
    /// What is painted on it.
    pub pattern: Pattern,
}

/// Where a ray meets the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The distance along the (unit or not) ray direction, in its units.
    pub t: f64,
    /// The point hit, world frame.
    pub point: Vector3<f64>,
    /// The texture's grey level there, 0–255.
    pub grey: f64,
}

/// The side of one texture cell, metres: a checkerboard of random grey levels
/// whose every vertex is a corner of distinct contrast (unique for NCC).
pub const TEXTURE_CELL_M: f64 = 0.25;

/// A hash of three integers to `[0, 1)` (splitmix64).
fn hash01(seed: u64, i: i64, j: i64) -> f64 {
    let mut z = seed
        .wrapping_add((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add((j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

impl TexturedQuad {
    /// The grey level at texture coordinates `(a, b)` metres from `origin`
    /// along the two edges: a grid of [`TEXTURE_CELL_M`] cells, each a random
    /// grey in 20–235, with a round dark or light blob in one cell out of
    /// four (corners of a second kind).
    pub fn texture(&self, a: f64, b: f64) -> f64 {
        if self.pattern == Pattern::ReferenceSheet {
            let (w, h) = (self.edge_u.norm(), self.edge_v.norm());
            let m = REFERENCE_MARGIN_M;
            let inside = a > m && a < w - m && b > m && b < h - m;
            return if inside { 20.0 } else { 235.0 };
        }
        let (fi, fj) = (a / TEXTURE_CELL_M, b / TEXTURE_CELL_M);
        let (i, j) = (fi.floor() as i64, fj.floor() as i64);
        let cell = 20.0 + 215.0 * hash01(self.texture_seed, i, j);
        if hash01(self.texture_seed ^ 0x5555, i, j) < 0.25 {
            let (du, dv) = (fi - i as f64 - 0.5, fj - j as f64 - 0.5);
            if du * du + dv * dv < 0.09 {
                return 255.0 - cell;
            }
        }
        cell
    }

    /// The texture's value at a world point on the quad.
    pub fn texture_at(&self, point: &Vector3<f64>) -> f64 {
        let d = point - self.origin;
        self.texture(
            d.dot(&self.edge_u) / self.edge_u.norm(),
            d.dot(&self.edge_v) / self.edge_v.norm(),
        )
    }

    /// The ray `origin + t·dir` against this quad: the hit with the smallest
    /// `t > 1e-9`, or `None`.
    pub fn intersect(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<Hit> {
        let normal = self.edge_u.cross(&self.edge_v);
        let denom = normal.dot(dir);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = normal.dot(&(self.origin - origin)) / denom;
        if t <= 1e-9 {
            return None;
        }
        let point = origin + dir * t;
        let d = point - self.origin;
        let (lu, lv) = (self.edge_u.norm_squared(), self.edge_v.norm_squared());
        let (s, r) = (d.dot(&self.edge_u) / lu, d.dot(&self.edge_v) / lv);
        if !(0.0..=1.0).contains(&s) || !(0.0..=1.0).contains(&r) {
            return None;
        }
        Some(Hit {
            t,
            point,
            grey: self.texture(s * lu.sqrt(), r * lv.sqrt()),
        })
    }
}

/// A scene: textured quads and a background grey for rays that hit nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The faces.
    pub quads: Vec<TexturedQuad>,
    /// The grey of empty space.
    pub background: f64,
}

impl Scene {
    /// The nearest hit of a ray, if any.
    pub fn cast(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<Hit> {
        self.quads
            .iter()
            .filter_map(|q| q.intersect(origin, dir))
            .min_by(|a, b| a.t.total_cmp(&b.t))
    }

    /// A room seen from inside (camera frame convention of KITTI: x right,
    /// y down, z forward; the camera starts at the origin looking along +z):
    /// back wall at z = 8 m, side walls at x = ±4 m, floor at y = 1.5 m,
    /// ceiling at y = −2.5 m, and three boxes on the floor. `seed` varies the
    /// textures only.
    pub fn room(seed: u64) -> Self {
        let mut quads = Vec::new();
        let mut add = |origin: [f64; 3], u: [f64; 3], v: [f64; 3]| {
            let k = quads.len() as u64;
            quads.push(TexturedQuad {
                origin: Vector3::from(origin),
                edge_u: Vector3::from(u),
                edge_v: Vector3::from(v),
                texture_seed: seed.wrapping_mul(1000).wrapping_add(k),
                pattern: Pattern::Cells,
            });
        };
        add([-4.0, -2.5, 8.0], [8.0, 0.0, 0.0], [0.0, 4.0, 0.0]); // back wall
        add([-4.0, 1.5, -3.0], [8.0, 0.0, 0.0], [0.0, 0.0, 11.0]); // floor
        add([-4.0, -2.5, -3.0], [8.0, 0.0, 0.0], [0.0, 0.0, 11.0]); // ceiling
        add([-4.0, -2.5, -3.0], [0.0, 4.0, 0.0], [0.0, 0.0, 11.0]); // left wall
        add([4.0, -2.5, -3.0], [0.0, 4.0, 0.0], [0.0, 0.0, 11.0]); // right wall
        add([-4.0, -2.5, -3.0], [8.0, 0.0, 0.0], [0.0, 4.0, 0.0]); // wall behind
        let boxes = [
            ([-2.2, 0.7, 4.0], [1.0, 0.8, 1.0]),
            ([0.6, 0.3, 5.0], [1.2, 1.2, 0.8]),
            ([-0.6, 0.9, 3.0], [0.6, 0.6, 0.6]),
        ];
        for (min, size) in boxes {
            let [x, y, z] = min;
            let [w, h, d] = size;
            add([x, y, z], [w, 0.0, 0.0], [0.0, h, 0.0]); // front
            add([x, y, z + d], [w, 0.0, 0.0], [0.0, h, 0.0]); // back
            add([x, y, z], [0.0, 0.0, d], [0.0, h, 0.0]); // left
            add([x + w, y, z], [0.0, 0.0, d], [0.0, h, 0.0]); // right
            add([x, y, z], [w, 0.0, 0.0], [0.0, 0.0, d]); // top
        }
        Self {
            quads,
            background: 128.0,
        }
    }

    /// The same scene with the paper's metric reference hung in it: a
    /// 0.5 × 0.4 m white sheet facing the camera's start, 2.6 m ahead and
    /// 0.5 m to the left of its path, with a black 0.3 × 0.2 m rectangle
    /// (the paper's sheet) in the middle. Returns the scene and the
    /// rectangle's four corners, world frame: the known points.
    #[must_use]
    pub fn with_reference_sheet(mut self) -> (Self, [Vector3<f64>; 4]) {
        let origin = Vector3::new(-1.0, -0.3, 2.6);
        let (edge_u, edge_v) = (Vector3::new(0.5, 0.0, 0.0), Vector3::new(0.0, 0.4, 0.0));
        self.quads.push(TexturedQuad {
            origin,
            edge_u,
            edge_v,
            texture_seed: 0,
            pattern: Pattern::ReferenceSheet,
        });
        let (u, v) = (edge_u.normalize(), edge_v.normalize());
        let m = REFERENCE_MARGIN_M;
        let (w, h) = (edge_u.norm() - m, edge_v.norm() - m);
        let corner = |a: f64, b: f64| origin + u * a + v * b;
        (
            self,
            [corner(m, m), corner(w, m), corner(w, h), corner(m, h)],
        )
    }
}

/// The white margin round the black rectangle of the reference sheet,
/// metres.
pub const REFERENCE_MARGIN_M: f64 = 0.1;

/// A smooth 6-DOF camera path through [`Scene::room`], a function of time:
/// forward along +z at 0.4 m/s while swaying sideways (±0.6 m, 8 s period)
/// and up and down (±0.15 m), yawing ±0.2 rad, pitching ±0.08 rad and
/// rolling ±0.05 rad. Starts at the origin with the identity orientation
/// plus the oscillations' phase (zero at t = 0), so the first pose is the
/// identity as in KITTI.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraPath {
    /// Forward speed, m/s.
    pub forward_speed: f64,
    /// Sideways amplitude, m.
    pub sway_m: f64,
    /// Yaw amplitude, rad.
    pub yaw_rad: f64,
}

impl Default for CameraPath {
    fn default() -> Self {
        Self {
            forward_speed: 0.4,
            sway_m: 0.6,
            yaw_rad: 0.2,
        }
    }
}

impl CameraPath {
    /// The camera-to-world pose at time `t` seconds.
    pub fn pose(&self, t: f64) -> CameraPose {
        use std::f64::consts::TAU;
        let w = TAU / 8.0;
        let position = Vector3::new(
            self.sway_m * (w * t).sin(),
            -0.15 * (2.0 * w * t).sin(),
            self.forward_speed * t,
        );
        // Yaw about the camera's y (down) axis, pitch about x, roll about z.
        let yaw = self.yaw_rad * (w * t).sin();
        let pitch = 0.08 * (1.3 * w * t).sin();
        let roll = 0.05 * (0.7 * w * t).sin();
        let orientation = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch)
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
        CameraPose {
            position,
            orientation,
        }
    }
}
