//! The Foxglove views of the SLAM trace: the `/slam/map` scene of an
//! estimate snapshot, the `/slam/particles` scene of a particle cloud and
//! the `/slam/events` log line of a filter decision (used by
//! [`crate::writer`]).

use bearing_slam_core::trace::{
    DiscardReason, EstimateSnapshot, InitMethod, ParticleCloud, RemovalCause, SlamEvent,
    TrackRefusal,
};

use crate::foxglove::{
    self as fx, Color, LinePrimitive, Pose, SceneEntity, SceneEntityDeletion, SceneUpdate,
    SpherePrimitive, TextPrimitive, Time, Vector3,
};

/// The `/slam/map` scene of a snapshot: one entity per landmark (sphere, 2σ
/// ellipse, label; blue when Euclidean, orange in inverse depth) and the
/// robot's 2σ position ellipse in red. Replaces the previous map entirely.
pub(crate) fn map_scene(stamp: Time, s: &EstimateSnapshot) -> SceneUpdate {
    let ellipse = |x: f64, y: f64, cov: [[f64; 2]; 2], color: Color| LinePrimitive {
        kind: fx::line_type::LINE_STRIP,
        pose: Pose::at(0.0, 0.0, 0.0),
        thickness: 1.5,
        scale_invariant: true,
        points: fx::covariance_ellipse(x, y, cov, 2.0, 48)
            .into_iter()
            .map(|[px, py]| Vector3::xy(px, py))
            .collect(),
        color,
        colors: Vec::new(),
        indices: Vec::new(),
    };
    let mut entities: Vec<SceneEntity> = s
        .landmarks
        .iter()
        .map(|l| {
            let color = if l.inverse_depth {
                Color::rgba(1.0, 0.55, 0.1, 1.0)
            } else {
                Color::rgba(0.2, 0.45, 1.0, 1.0)
            };
            let mut e = SceneEntity::new(stamp, fx::WORLD_FRAME, format!("landmark_{}", l.id));
            e.spheres.push(SpherePrimitive {
                pose: Pose::at(l.x, l.y, 0.0),
                size: Vector3 {
                    x: 0.15,
                    y: 0.15,
                    z: 0.15,
                },
                color,
            });
            e.lines.push(ellipse(l.x, l.y, l.covariance, color));
            e.texts
                .push(TextPrimitive::label(l.x, l.y, format!("{}", l.id), color));
            e.metadata.push(fx::KeyValuePair {
                key: "inverse_depth".into(),
                value: l.inverse_depth.to_string(),
            });
            e
        })
        .collect();
    let c = s.pose_covariance;
    let mut robot = SceneEntity::new(stamp, fx::WORLD_FRAME, "robot_covariance".into());
    robot.lines.push(ellipse(
        s.pose.x,
        s.pose.y,
        [[c[0][0], c[0][1]], [c[1][0], c[1][1]]],
        Color::rgba(1.0, 0.2, 0.2, 1.0),
    ));
    entities.push(robot);
    SceneUpdate {
        deletions: vec![SceneEntityDeletion::all(stamp)],
        entities,
    }
}

/// Length of a particle's heading tick on `/slam/particles`, metres.
const PARTICLE_TICK_M: f64 = 0.08;

/// The `/slam/particles` scene of a cloud: one heading tick per particle (a
/// segment from its position along its heading), green; the best particle's
/// in red and longer. Replaces the previous cloud.
pub(crate) fn particles_scene(stamp: Time, cloud: &ParticleCloud) -> SceneUpdate {
    let tick = |p: &bearing_slam_core::Pose2, len: f64| {
        [
            Vector3::xy(p.x, p.y),
            Vector3::xy(p.x + len * p.theta.cos(), p.y + len * p.theta.sin()),
        ]
    };
    let lines = |points: Vec<Vector3>, color: Color, thickness: f64| LinePrimitive {
        kind: fx::line_type::LINE_LIST,
        pose: Pose::at(0.0, 0.0, 0.0),
        thickness,
        scale_invariant: true,
        points,
        color,
        colors: Vec::new(),
        indices: Vec::new(),
    };
    let mut e = SceneEntity::new(stamp, fx::WORLD_FRAME, "particles".into());
    let all = cloud
        .poses
        .iter()
        .flat_map(|p| tick(p, PARTICLE_TICK_M))
        .collect();
    e.lines
        .push(lines(all, Color::rgba(0.1, 0.7, 0.3, 0.6), 1.0));
    if let Some(best) = cloud.poses.get(cloud.best) {
        e.lines.push(lines(
            tick(best, 2.5 * PARTICLE_TICK_M).to_vec(),
            Color::rgba(1.0, 0.2, 0.2, 1.0),
            2.5,
        ));
    }
    e.metadata.push(fx::KeyValuePair {
        key: "particles".into(),
        value: cloud.poses.len().to_string(),
    });
    SceneUpdate {
        deletions: vec![SceneEntityDeletion::all(stamp)],
        entities: vec![e],
    }
}

/// Level and text of the `/slam/events` log line of a filter decision.
pub(crate) fn describe(event: &SlamEvent) -> (u8, String) {
    use fx::level::{DEBUG, ERROR, INFO, WARNING};
    match event {
        SlamEvent::CandidateCreated { id } => (DEBUG, format!("candidate landmark {id} created")),
        SlamEvent::CandidateExpired { id } => (WARNING, format!("candidate landmark {id} expired")),
        SlamEvent::LandmarkInitialized {
            id,
            method,
            parallax_rad,
        } => {
            let method = match method {
                InitMethod::PiSr => "PI-SR (undelayed inverse depth)",
                InitMethod::Triangulated => "stochastic triangulation",
                InitMethod::TriangulatedClone => "stochastic triangulation with pose clone",
                InitMethod::Far => "far-landmark prior",
                InitMethod::RangeBearing => "range-bearing",
            };
            (
                INFO,
                format!(
                    "landmark {id} initialized by {method} (parallax {:.3} deg)",
                    parallax_rad.to_degrees()
                ),
            )
        }
        SlamEvent::LandmarkConverted {
            id,
            linearity_index,
        } => (
            INFO,
            format!("landmark {id} converted to Euclidean (linearity index {linearity_index:.4})"),
        ),
        SlamEvent::MeasurementRejected { id, nis } if *nis == f64::MAX => (
            WARNING,
            format!(
                "measurement of landmark {id} rejected: degenerate prediction (landmark at the sensor)"
            ),
        ),
        SlamEvent::MeasurementRejected { id, nis } => (
            WARNING,
            format!("measurement of landmark {id} rejected by the gate (NIS {nis:.2})"),
        ),
        SlamEvent::BearingsDiscarded { id, count, reason } => (
            if matches!(
                reason,
                DiscardReason::NoHistory | DiscardReason::HistoryFull
            ) {
                DEBUG
            } else {
                WARNING
            },
            format!(
                "{count} bearing(s) of candidate landmark {id} not used: {}",
                match reason {
                    DiscardReason::NoHistory => "seen while waiting (no history kept)",
                    DiscardReason::HistoryFull => "seen while waiting (history full)",
                    DiscardReason::Decimated => "left out by the replay's decimation",
                    DiscardReason::Restarted => "the candidate restarted",
                    DiscardReason::Expired => "the candidate expired",
                    DiscardReason::FarFirstBearing => "first bearing of a far landmark",
                    DiscardReason::WaitBudget =>
                        "first bearing of a landmark that waited out its budget",
                    DiscardReason::ParallaxStalled => {
                        "first bearing of a landmark whose parallax stalled"
                    }
                }
            ),
        ),
        SlamEvent::Diverging {
            window_nis,
            dof,
            bound,
        } => (
            ERROR,
            format!(
                "filter diverging: windowed NIS {window_nis:.1} over {dof} dof, \
                 {:.1} times its chi-square bound {bound:.1}",
                window_nis / bound
            ),
        ),
        SlamEvent::MeasurementDownWeighted { id, nis, weight } => (
            INFO,
            format!(
                "measurement of landmark {id} down-weighted (NIS {nis:.2}, Huber weight {weight:.3})"
            ),
        ),
        SlamEvent::MeasurementReadmitted {
            id,
            nis,
            gated_in_row,
        } => (
            WARNING,
            format!(
                "measurement of landmark {id} re-admitted with inflated noise (NIS {nis:.2}) \
                 after {gated_in_row} gated in a row"
            ),
        ),
        SlamEvent::PairingSetAside { id, probability } => (
            INFO,
            format!(
                "bearing paired with landmark {id} set aside: posterior probability {probability:.3}"
            ),
        ),
        SlamEvent::LandmarkRemoved { id, cause } => {
            let why = match cause {
                RemovalCause::MovingObject => "a moving object (its bearings stopped fitting it)",
                RemovalCause::RarelyPaired => "rarely paired (moved away, or out of view)",
                RemovalCause::Duplicate => "the same point as an older landmark",
                RemovalCause::Replaced => "lost, and replaced by a track that looks like it",
            };
            (
                WARNING,
                format!("landmark {id} removed from the map: {why}"),
            )
        }
        SlamEvent::TrackNotMapped { id, cause } => {
            let why = match cause {
                TrackRefusal::MappedLandmark => "a mapped landmark explains it",
                TrackRefusal::RememberedMover => "a mover removed from the map explains it",
                TrackRefusal::LookAlike => "a mapped landmark that looks like it is still seen",
            };
            (DEBUG, format!("track {id} not mapped: {why}"))
        }
    }
}
