//! Every parameter of the peer estimators' configurations at the edges of
//! its range: the last value accepted and the first refused, with the error
//! naming the parameter. (Found missing by the estimators' mutation
//! samples of issue 20: a bound off by one comparison went unnoticed.)

use bearing_slam_core::Pose2;
use bearing_slam_core::error::{Result, SlamError};
use bearing_slam_core::particle::config::MAX_PARTICLES;
use bearing_slam_core::particle::existence::ExistenceConfig;
use bearing_slam_core::particle::kld::KldConfig;
use bearing_slam_core::particle::landmark_ekf::SensorNoise;
use bearing_slam_core::particle::mcl::{AugmentedConfig, Bounds};
use bearing_slam_core::particle::{FastSlamConfig, FastSlamVariant, MclConfig};
use bearing_slam_core::runner::RunConfig;
use bearing_slam_core::slam::SlamConfig;
use bearing_slam_core::smoother::{
    FixedLagConfig, FixedLagSmoother, KeyframeRule, OnlineSmoother, RayTriangulationRule,
    RobustKernel, SmootherConfig, SolverConfig,
};
use std::f64::consts::PI;

/// The check under test.
type Validate<C> = Box<dyn Fn(&C) -> Result<()>>;

/// A valid configuration and its check, tried at edges one by one.
struct Edges<C> {
    base: C,
    validate: Validate<C>,
}

impl<C: Clone> Edges<C> {
    fn new(base: C, validate: impl Fn(&C) -> Result<()> + 'static) -> Self {
        validate(&base).expect("the base configuration is valid");
        Self {
            base,
            validate: Box::new(validate),
        }
    }

    fn changed(&self, change: impl Fn(&mut C)) -> Result<()> {
        let mut c = self.base.clone();
        change(&mut c);
        (self.validate)(&c)
    }

    /// `change` stays in range.
    fn ok(&self, what: &str, change: impl Fn(&mut C)) -> &Self {
        if let Err(e) = self.changed(change) {
            panic!("{what}: refused, but it is in range: {e}");
        }
        self
    }

    /// `change` is out of range, and the error names `named`.
    fn refused(&self, what: &str, change: impl Fn(&mut C), named: &str) -> &Self {
        match self.changed(change) {
            Ok(()) => panic!("{what}: accepted, but {named} is out of range"),
            Err(e) => assert!(
                e.to_string().contains(named),
                "{what}: the error does not name {named}: {e}"
            ),
        }
        self
    }
}

/// Both particle filters resample when `N_eff < threshold · M`, the
/// threshold in `(0, 1]`.
fn resample_threshold_edges<C: Clone>(edges: &Edges<C>, threshold: fn(&mut C) -> &mut f64) {
    edges
        .ok("resample always", |c| *threshold(c) = 1.0)
        .refused(
            "resample never",
            |c| *threshold(c) = 0.0,
            "resample_threshold",
        )
        .refused(
            "threshold > 1",
            |c| *threshold(c) = 1.01,
            "resample_threshold",
        );
}

#[test]
fn fastslam_configuration_edges() {
    let edges = Edges::new(FastSlamConfig::default(), FastSlamConfig::validate);
    resample_threshold_edges(&edges, |c| &mut c.resample_threshold);
    edges
        .ok("one particle", |c| c.particles = 1)
        .refused("no particle", |c| c.particles = 0, "particles")
        .ok("the most particles", |c| c.particles = MAX_PARTICLES)
        .refused(
            "more particles than a run can hold",
            |c| c.particles = MAX_PARTICLES + 1,
            "particles",
        )
        .refused(
            "10¹² particles",
            |c| c.particles = 1_000_000_000_000,
            "particles",
        )
        .refused("NaN x", |c| c.initial_pose.x = f64::NAN, "initial x")
        .refused("∞ y", |c| c.initial_pose.y = f64::INFINITY, "initial y")
        .refused(
            "NaN θ",
            |c| c.initial_pose.theta = f64::NAN,
            "initial theta",
        )
        .ok("an exact start", |c| c.initial_pose_sigma = [0.0; 3])
        .refused(
            "σ < 0",
            |c| c.initial_pose_sigma[1] = -1e-9,
            "initial pose sigma",
        )
        .refused(
            "σ = ∞",
            |c| c.initial_pose_sigma[2] = f64::INFINITY,
            "initial pose sigma",
        )
        .refused("σ_z = 0", |c| c.noise.bearing_sigma = 0.0, "bearing sigma")
        .refused("σ_r < 0", |c| c.noise.range_sigma = -0.1, "range sigma")
        .ok("never convert", |c| c.conversion_threshold = None)
        .ok("convert at 1", |c| c.conversion_threshold = Some(1.0))
        .refused(
            "convert at 0",
            |c| c.conversion_threshold = Some(0.0),
            "conversion_threshold",
        )
        .refused(
            "convert above 1",
            |c| c.conversion_threshold = Some(1.0 + 1e-12),
            "conversion_threshold",
        )
        .ok("2.0 resampling first", |c| {
            c.resample_before_proposal = true
        })
        .refused(
            "1.0 resampling first",
            |c| {
                c.variant = FastSlamVariant::FastSlam1;
                c.resample_before_proposal = true;
            },
            "resample_before_proposal",
        )
        .ok("1.0 in order", |c| c.variant = FastSlamVariant::FastSlam1)
        .ok("an existence counter", |c| {
            c.existence = Some(ExistenceConfig::default())
        })
        .refused(
            "a bad existence counter",
            |c| {
                c.existence = Some(ExistenceConfig {
                    miss_decrement: 0.0,
                    ..ExistenceConfig::default()
                });
            },
            "miss_decrement",
        );
}

#[test]
fn existence_configuration_edges() {
    Edges::new(ExistenceConfig::default(), ExistenceConfig::validate)
        .refused("blind", |c| c.max_range_m = 0.0, "max_range_m")
        .refused("no field of view", |c| c.half_fov_rad = 0.0, "half_fov_rad")
        .ok("all around", |c| c.half_fov_rad = PI)
        .refused(
            "more than all around",
            |c| c.half_fov_rad = PI + 1e-9,
            "half_fov_rad",
        )
        .refused(
            "NaN field of view",
            |c| c.half_fov_rad = f64::NAN,
            "half_fov_rad",
        )
        .refused(
            "no evidence per sighting",
            |c| c.seen_increment = 0.0,
            "seen_increment",
        )
        .refused(
            "no cost per miss",
            |c| c.miss_decrement = 0.0,
            "miss_decrement",
        )
        .refused(
            "never removed",
            |c| c.remove_below = f64::NEG_INFINITY,
            "remove_below",
        )
        .ok("a cap of one sighting", |c| {
            c.max_evidence = c.seen_increment
        })
        .refused(
            "a cap below one sighting",
            |c| c.max_evidence = 0.5 * c.seen_increment,
            "max_evidence",
        );
}

#[test]
fn kld_configuration_edges() {
    Edges::new(KldConfig::default(), KldConfig::validate)
        .refused("ε = 0", |c| c.epsilon = 0.0, "epsilon")
        .refused("δ = 0", |c| c.delta = 0.0, "delta")
        .refused("ε = ∞", |c| c.epsilon = f64::INFINITY, "epsilon")
        .refused("no x-y bins", |c| c.bin_xy_m = 0.0, "bin_xy_m")
        .refused(
            "no heading bins",
            |c| c.bin_theta_rad = 0.0,
            "bin_theta_rad",
        )
        .ok("one particle at least", |c| c.min_particles = 1)
        .refused("none at least", |c| c.min_particles = 0, "min_particles")
        .ok("a fixed count", |c| c.max_particles = c.min_particles)
        .refused(
            "more particles than a run can hold",
            |c| c.max_particles = MAX_PARTICLES + 1,
            "max_particles",
        )
        .refused(
            "a maximum below the minimum",
            |c| c.max_particles = c.min_particles - 1,
            "max_particles",
        );
}

fn mcl_base() -> MclConfig {
    MclConfig {
        particles: 10,
        seed: 0,
        bounds: Bounds {
            x_min: 0.0,
            x_max: 1.0,
            y_min: 0.0,
            y_max: 1.0,
        },
        bearing_sigma: 0.02,
        outlier_probability: 0.05,
        resample_threshold: 0.5,
        augmented: Some(AugmentedConfig::default()),
        kld: Some(KldConfig::default()),
        roughening: 0.2,
    }
}

#[test]
fn mcl_bounds_report_their_shorter_side() {
    let mut config = mcl_base();
    config.bounds.y_max = -0.5;
    match config.validate() {
        Err(SlamError::InvalidParameter { name, value, .. }) => {
            assert_eq!((name, value), ("bounds", -0.5));
        }
        other => panic!("a 1 × −0.5 m room: {other:?}"),
    }
}

#[test]
fn mcl_configuration_edges() {
    let edges = Edges::new(mcl_base(), MclConfig::validate);
    resample_threshold_edges(&edges, |c| &mut c.resample_threshold);
    edges
        .refused("no particle", |c| c.particles = 0, "particles")
        .refused(
            "more particles than a run can hold",
            |c| c.particles = MAX_PARTICLES + 1,
            "particles",
        )
        .refused("a flat room", |c| c.bounds.x_max = c.bounds.x_min, "bounds")
        .refused("an upside-down room", |c| c.bounds.y_max = -1.0, "bounds")
        .refused(
            "a room without depth",
            |c| c.bounds.y_max = c.bounds.y_min,
            "bounds",
        )
        .refused("NaN bounds", |c| c.bounds.y_min = f64::NAN, "bounds y_min")
        .refused("σ_z = 0", |c| c.bearing_sigma = 0.0, "bearing sigma")
        .ok("no outliers", |c| c.outlier_probability = 0.0)
        .refused(
            "only outliers",
            |c| c.outlier_probability = 1.0,
            "outlier_probability",
        )
        .refused(
            "negative outliers",
            |c| c.outlier_probability = -0.01,
            "outlier_probability",
        )
        .ok("no augmentation", |c| c.augmented = None)
        .ok("α_slow = 0, α_fast = 1", |c| {
            c.augmented = Some(AugmentedConfig {
                alpha_slow: 0.0,
                alpha_fast: 1.0,
            });
        })
        .refused(
            "α_slow < 0",
            |c| {
                c.augmented = Some(AugmentedConfig {
                    alpha_slow: -0.01,
                    alpha_fast: 0.2,
                });
            },
            "alpha_slow",
        )
        .refused(
            "α_slow = α_fast",
            |c| {
                c.augmented = Some(AugmentedConfig {
                    alpha_slow: 0.2,
                    alpha_fast: 0.2,
                });
            },
            "alpha_slow",
        )
        .refused(
            "α_fast > 1",
            |c| {
                c.augmented = Some(AugmentedConfig {
                    alpha_slow: 0.1,
                    alpha_fast: 1.1,
                });
            },
            "alpha_slow",
        )
        .refused(
            "a bad KLD",
            |c| {
                c.kld = Some(KldConfig {
                    epsilon: -1.0,
                    ..KldConfig::default()
                });
            },
            "epsilon",
        )
        .ok("no roughening", |c| c.roughening = 0.0)
        .refused("negative roughening", |c| c.roughening = -0.1, "roughening")
        .refused(
            "∞ roughening",
            |c| c.roughening = f64::INFINITY,
            "roughening",
        );
}

#[test]
fn sensor_noise_edges() {
    let base = SensorNoise {
        bearing_sigma: 0.01,
        range_sigma: 0.1,
    };
    Edges::new(base, SensorNoise::validate)
        .refused("σ_z = 0", |c| c.bearing_sigma = 0.0, "bearing sigma")
        .refused("σ_r = NaN", |c| c.range_sigma = f64::NAN, "range sigma");
}

#[test]
fn solver_configuration_edges() {
    let edges = Edges::new(SolverConfig::default(), SolverConfig::validate);
    edges
        .ok("one iteration", |c| c.max_iterations = 1)
        .refused("no iteration", |c| c.max_iterations = 0, "max_iterations")
        .ok("least squares", |c| c.robust = RobustKernel::None)
        .refused(
            "Huber(0)",
            |c| c.robust = RobustKernel::Huber(0.0),
            "robust kernel",
        )
        .refused(
            "Cauchy(∞)",
            |c| c.robust = RobustKernel::Cauchy(f64::INFINITY),
            "robust kernel",
        );
    // Each tolerance may be 0, never negative or NaN.
    type Field = fn(&mut SolverConfig) -> &mut f64;
    let fields: [(&str, Field); 6] = [
        ("relative_tolerance", |c| &mut c.relative_tolerance),
        ("absolute_tolerance", |c| &mut c.absolute_tolerance),
        ("step_tolerance", |c| &mut c.step_tolerance),
        ("gradient_tolerance", |c| &mut c.gradient_tolerance),
        ("initial_lambda", |c| &mut c.initial_lambda),
        ("decrement_tolerance", |c| &mut c.decrement_tolerance),
    ];
    for (name, field) in fields {
        edges
            .ok(name, |c| *field(c) = 0.0)
            .refused(name, |c| *field(c) = -1e-12, name)
            .refused(name, |c| *field(c) = f64::NAN, name);
    }
}

#[test]
fn ray_triangulation_rule_edges() {
    Edges::new(
        RayTriangulationRule::new(0.01, 0.1),
        RayTriangulationRule::validate,
    )
    .refused("σ = 0", |c| c.bearing_sigma = 0.0, "bearing_sigma")
    .refused("no parallax", |c| c.min_parallax = 0.0, "min_parallax")
    .refused("no depth", |c| c.min_depth = 0.0, "min_depth")
    .refused("NaN depth", |c| c.min_depth = f64::NAN, "min_depth")
    .refused("no inlier band", |c| c.inlier_sigmas = 0.0, "inlier_sigmas")
    .ok("every ray an inlier", |c| c.min_inlier_fraction = 1.0)
    .refused(
        "no inlier needed",
        |c| c.min_inlier_fraction = 0.0,
        "min_inlier_fraction",
    )
    .refused(
        "more than all",
        |c| c.min_inlier_fraction = 1.01,
        "min_inlier_fraction",
    )
    .ok("two rays", |c| c.min_inliers = 2)
    .refused("one ray", |c| c.min_inliers = 1, "min_inliers");
}

#[test]
fn fixed_lag_and_keyframe_edges() {
    let lag = |lag| FixedLagConfig {
        lag,
        ..FixedLagConfig::default()
    };
    assert!(FixedLagSmoother::new(lag(2)).is_ok());
    let e = FixedLagSmoother::new(lag(1)).expect_err("a one-pose window");
    assert!(e.to_string().contains("lag"), "{e}");
    let bad_solver = FixedLagConfig {
        solver: SolverConfig {
            max_iterations: 0,
            ..SolverConfig::default()
        },
        ..lag(5)
    };
    assert!(FixedLagSmoother::new(bad_solver).is_err());

    let run_config = RunConfig {
        slam: SlamConfig::default(),
        odometry: bearing_slam_core::runner::OdometryConfig::Wheels(
            bearing_slam_core::motion::DiffDriveModel::new(
                0.2,
                bearing_slam_core::runner::DEFAULT_WHEEL_NOISE,
            )
            .expect("valid"),
        ),
        use_range: false,
    };
    let with_rule = move |rule: &KeyframeRule| {
        let config = SmootherConfig {
            keyframes: Some(*rule),
            ..SmootherConfig::default()
        };
        OnlineSmoother::new(
            SlamConfig {
                initial_pose: Pose2::new(1.0, 2.0, 0.5),
                ..SlamConfig::default()
            },
            &run_config,
            &config,
            FixedLagConfig::default(),
        )
        .map(|_| ())
    };
    Edges::new(KeyframeRule::default(), with_rule)
        .ok("every motion a keyframe", |c| {
            c.min_translation_m = 0.0;
            c.min_rotation_rad = 0.0;
        })
        .refused(
            "negative translation",
            |c| c.min_translation_m = -0.1,
            "min_translation_m",
        )
        .refused(
            "NaN rotation",
            |c| c.min_rotation_rad = f64::NAN,
            "min_rotation_rad",
        )
        .ok("one scan per keyframe", |c| c.max_scans = 1)
        .refused("no scan per keyframe", |c| c.max_scans = 0, "max_scans");
}
