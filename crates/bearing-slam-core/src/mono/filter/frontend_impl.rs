//! [`MonoFilter`] for [`MonoSlam`]: the filter as an image front end drives
//! it, one frame at a time (Munguía & Grau §"SLAM monocular"): predict by the
//! constant-velocity model (25), the search regions from `S_i` (30), the
//! batched pixel update (29) with candidates seen, missed and converted, and
//! new features proposed by the front end.

use super::{FeatureOrigin, MonoSlam, MonoUpdateReport};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::mono::frontend::{CameraPose, MapPoint, MonoFilter, PixelObservation, SearchRegion};
use crate::mono::init::{MonoInitializer, world_ray};
use crate::mono::landmark::ray_angles;
use crate::mono::motion::{CAMERA_DIM, QUATERNION};
use nalgebra::{Matrix2, UnitQuaternion, Vector2, Vector3};

impl MonoFilter for MonoSlam {
    fn predict(&mut self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "dt",
                value: dt,
                reason: "time step must be positive and finite",
            });
        }
        self.ekf
            .predict::<CAMERA_DIM, _>(&self.config.motion, &dt)?;
        self.frame_clone = None;
        Ok(())
    }

    fn search_regions(&self) -> Result<Vec<SearchRegion>> {
        let camera = self.config.camera;
        let mut regions = Vec::with_capacity(self.landmarks.len() + self.candidates.len());
        for (&id, feature) in &self.landmarks {
            // Behind the camera or off the image: not searched.
            if let Some(region) = self.landmark_region(id, feature) {
                regions.push(region);
            }
        }
        for (&id, pending) in &self.candidates {
            if let Some(search) = self.config.epipolar {
                if let Ok(Some((px, segment))) = self.candidate_segment(pending, &search) {
                    let (_, s) = self.candidate_region(pending).unwrap_or((
                        px,
                        Matrix2::identity() * self.config.candidate_search_sigma.powi(2),
                    ));
                    regions.push(SearchRegion {
                        feature_id: id,
                        predicted_px: px,
                        innovation_cov: s,
                        segment: Some(segment),
                    });
                }
                continue;
            }
            if let Ok((px, s)) = self.candidate_region(pending)
                && camera.contains(&px)
            {
                regions.push(SearchRegion {
                    feature_id: id,
                    predicted_px: px,
                    innovation_cov: s,
                    segment: None,
                });
            }
        }
        Ok(regions)
    }

    fn update(&mut self, found: &[PixelObservation], missed: &[u64]) -> Result<()> {
        self.check_frame(found, missed)?;
        self.last_report = MonoUpdateReport::default();
        // Out of view at the predicted state, the one the regions came from.
        let unseen = if self.config.forget_out_of_view {
            self.out_of_view(found, missed)
        } else {
            Vec::new()
        };
        let rejected = self.update_map(found)?;
        if self.last_report.used > 0 {
            // The camera moved: later candidates need a clone of the new pose.
            self.frame_clone = None;
        }
        let (mut initialized, mut dropped) = (0, 0);
        for o in found {
            if !self.candidates.contains_key(&o.feature_id) {
                continue;
            }
            match self.candidate_seen(o.feature_id, &o.px) {
                Ok(true) => initialized += 1,
                Ok(false) => {}
                // Degenerate geometry for this candidate only (a ray along
                // the vertical, no far prior): it leaves, the frame goes on.
                Err(_) => {
                    self.drop_candidate(o.feature_id)?;
                    dropped += 1;
                }
            }
        }
        let mut leaving = Vec::new();
        for &id in missed.iter().chain(rejected.iter()).chain(unseen.iter()) {
            if self.missed(id, &mut leaving)? {
                dropped += 1;
            }
        }
        self.remove_landmarks(&leaving)?;
        let converted = self.convert_linear_landmarks()?;
        self.last_report.initialized = initialized;
        self.last_report.dropped = dropped;
        self.last_report.converted = converted;
        Ok(())
    }

    fn add_features(&mut self, px: &[Vector2<f64>]) -> Result<Vec<u64>> {
        // Every pixel checked before any enters: an error leaves the filter
        // unchanged (no feature without an id returned).
        let q = self.ekf.block::<4>(QUATERNION)?;
        for p in px {
            ensure_finite("pixel u", p.x)?;
            ensure_finite("pixel v", p.y)?;
            let ray = world_ray(&self.config.camera, &q, p)?;
            ray_angles(&ray.ray)?;
        }
        let mut ids = Vec::with_capacity(px.len());
        for p in px {
            match self.config.initializer {
                MonoInitializer::Undelayed { rho_ini, sigma_rho } => {
                    ensure_positive_noise("sigma_rho", sigma_rho)?;
                    let id = self.next_id;
                    self.insert_undelayed(id, p, rho_ini, sigma_rho, FeatureOrigin::Undelayed)?;
                    self.next_id += 1;
                    ids.push(id);
                }
                MonoInitializer::Delayed(_) | MonoInitializer::DelayedWithClone(_) => {
                    let pending = self.new_candidate(p)?;
                    let id = self.fresh_id();
                    self.candidates.insert(id, pending);
                    ids.push(id);
                }
            }
        }
        Ok(ids)
    }

    fn camera_pose(&self) -> CameraPose {
        let m = self.ekf.mean();
        let q = nalgebra::Quaternion::new(m[3], m[4], m[5], m[6]);
        CameraPose {
            position: Vector3::new(m[0], m[1], m[2]),
            orientation: UnitQuaternion::from_quaternion(q),
        }
    }

    fn landmarks(&self) -> Vec<MapPoint> {
        self.landmarks
            .keys()
            .filter(|&&id| self.depth_bounded(id))
            .filter_map(|&id| self.map_point(id).ok().flatten())
            .collect()
    }

    fn feature_points(&self) -> Vec<(u64, Vector3<f64>)> {
        self.feature_points_estimate()
    }
}
