//! A ground-truth oracle behind the [`MonoFilter`] trait, for testing and
//! timing the front end alone on a rendered sequence: it knows the true
//! camera pose of every frame and casts a ray into the [`Scene`] to place
//! every new feature exactly, so its predictions are exact and its
//! innovation covariance a fixed `σ² I`. It estimates nothing.

use crate::frames::{Intrinsics, project_world};
use crate::render::point_at_pixel;
use crate::scene::Scene;
use bearing_slam_core::mono::{CameraPose, MonoFilter, PixelObservation, SearchRegion};
use bearing_slam_core::{Result, SlamError};
use nalgebra::{Matrix2, Vector2, Vector3};
use std::collections::BTreeMap;

/// The oracle "filter".
#[derive(Clone, Debug)]
pub struct GroundTruthOracle {
    scene: Scene,
    intrinsics: Intrinsics,
    poses: Vec<CameraPose>,
    frame: usize,
    points: BTreeMap<u64, Vector3<f64>>,
    misses: BTreeMap<u64, u32>,
    next_id: u64,
    pixel_sigma: f64,
    max_misses: u32,
    /// The pixel error of every match the front end reported (found − true).
    pub residuals_px: Vec<f64>,
}

impl GroundTruthOracle {
    /// An oracle for a rendered sequence: its scene, intrinsics and the true
    /// pose of every frame; predictions carry `S = pixel_sigma² I`.
    pub fn new(
        scene: Scene,
        intrinsics: Intrinsics,
        poses: Vec<CameraPose>,
        pixel_sigma: f64,
    ) -> Result<Self> {
        if !(pixel_sigma.is_finite() && pixel_sigma > 0.0) {
            return Err(SlamError::InvalidNoise {
                what: "oracle pixel sigma",
                value: pixel_sigma,
            });
        }
        if poses.is_empty() {
            return Err(SlamError::InvalidParameter {
                name: "oracle poses",
                value: 0.0,
                reason: "at least one pose",
            });
        }
        Ok(Self {
            scene,
            intrinsics,
            poses,
            frame: 0,
            points: BTreeMap::new(),
            misses: BTreeMap::new(),
            next_id: 0,
            pixel_sigma,
            max_misses: 3,
            residuals_px: Vec::new(),
        })
    }

    /// The current frame index.
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// The number of features tracked.
    pub fn tracked(&self) -> usize {
        self.points.len()
    }
}

impl MonoFilter for GroundTruthOracle {
    fn predict(&mut self, _dt: f64) -> Result<()> {
        if self.frame + 1 >= self.poses.len() {
            return Err(SlamError::InvalidParameter {
                name: "oracle frame",
                value: (self.frame + 1) as f64,
                reason: "past the last ground-truth pose",
            });
        }
        self.frame += 1;
        Ok(())
    }

    fn search_regions(&self) -> Result<Vec<SearchRegion>> {
        let pose = &self.poses[self.frame];
        let cov = Matrix2::identity() * self.pixel_sigma * self.pixel_sigma;
        Ok(self
            .points
            .iter()
            .filter_map(|(&id, p)| {
                project_world(&self.intrinsics, pose, p).map(|px| SearchRegion {
                    feature_id: id,
                    predicted_px: px,
                    innovation_cov: cov,
                    segment: None,
                })
            })
            .collect())
    }

    fn update(&mut self, found: &[PixelObservation], missed: &[u64]) -> Result<()> {
        let pose = self.poses[self.frame];
        for obs in found {
            if let Some(p) = self.points.get(&obs.feature_id) {
                if let Some(truth) = project_world(&self.intrinsics, &pose, p) {
                    self.residuals_px.push((obs.px - truth).norm());
                }
                self.misses.insert(obs.feature_id, 0);
            }
        }
        for id in missed {
            let count = self.misses.entry(*id).or_insert(0);
            *count += 1;
            if *count > self.max_misses {
                self.points.remove(id);
                self.misses.remove(id);
            }
        }
        Ok(())
    }

    fn add_features(&mut self, px: &[Vector2<f64>]) -> Result<Vec<u64>> {
        let pose = self.poses[self.frame];
        let mut ids = Vec::with_capacity(px.len());
        for p in px {
            let id = self.next_id;
            self.next_id += 1;
            if let Some(point) = point_at_pixel(&self.scene, &self.intrinsics, &pose, p) {
                self.points.insert(id, point);
            }
            ids.push(id);
        }
        Ok(ids)
    }

    fn camera_pose(&self) -> CameraPose {
        self.poses[self.frame]
    }
}
