//! A graph-SLAM smoother, the peer of the EKF: it shares the filter's motion
//! and measurement models and refines the whole trajectory and map at once.
//!
//! * [`values`]: the variables, SE(2) poses at the measurement times and 2-D
//!   point landmarks (increments in the point or in inverse depth);
//! * [`preintegration`]: odometry between two poses integrated through the
//!   filter's motion model, covariance included;
//! * [`factors`] and [`graph`]: priors, preintegrated odometry, bearing
//!   (Munguía & Grau (9)) and range-bearing ((6)) factors, linear
//!   (marginalization) factors;
//! * [`solver`]: Levenberg–Marquardt / Gauss–Newton on the sparse normal
//!   equations (`faer`'s sparse Cholesky, symbolic analysis reused), with
//!   the [`robust`] kernels; [`normal_equations`] hands out the system it
//!   factors;
//! * [`marginals`]: per-variable covariances by the selected inverse of the
//!   sparse factor;
//! * [`fixed_lag`]: online fixed-lag smoothing, marginalizing the poses that
//!   leave the window into a linear prior (Schur complement, first-estimate
//!   Jacobians);
//! * [`online`]: [`OnlineSmoother`], the filter and the fixed-lag smoother
//!   run together event by event (an [`crate::online::OnlineEstimator`]);
//! * [`triangulate`]: multi-view triangulation of a point from rays at
//!   solved poses (the landmarks the filter never initialized);
//! * [`run`]: [`run_from_log`], the filter's run followed by the batch
//!   smoother (or the online one), returning the runner's output shape.

mod anchor_links;
pub mod factors;
pub mod fixed_lag;
pub mod graph;
pub mod marginals;
pub mod online;
pub mod preintegration;
pub mod robust;
pub mod run;
pub mod solver;
mod system;
pub mod triangulate;
pub mod values;

pub use factors::{
    BearingFactor, Factor, LandmarkPriorFactor, LinearFactor, Linearization, OdometryFactor,
    PosePriorFactor, RangeBearingFactor,
};
pub use fixed_lag::{FinalizedPose, FixedLagConfig, FixedLagSmoother, PriorAnchor};
pub use graph::FactorGraph;
pub use marginals::{Marginals, marginal_covariances};
pub use online::{
    KeyframeRule, OnlineReassociation, OnlineSmoother, OnlineStart, OnlineWindow,
    run_online_smoother,
};
pub use preintegration::PreintegratedOdometry;
pub use robust::RobustKernel;
pub use run::{
    BatchProblem, BatchStart, SmoothedRun, SmootherConfig, SmootherMode, SmootherReport,
    UnmappedTriangulation, batch_problem, run_from_log,
};
pub use solver::{Method, SolveReport, SolverConfig, Termination, cost, optimize};
pub use system::{SparseNormalEquations, normal_equations};
pub use triangulate::{RayPoint, RayTriangulationRule, triangulate_rays};
pub use values::{Key, LandmarkChart, Values};
