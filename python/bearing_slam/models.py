"""Motion, measurement and initialization models with their analytic Jacobians.

Every function returns numpy float64 arrays; Jacobians are named by what they
differentiate (``J_pose`` is ∂output/∂[x, y, θ]) and can be checked against
numeric differences. Equation numbers refer to Munguía & Grau.
"""

from bearing_slam._native import (
    bearing_to_inverse_depth,
    bearing_to_point,
    diff_drive,
    inverse_depth_to_point,
    inverse_range_bearing,
    linearity_index,
    odometry,
    odometry_increment,
    pi_sr_init,
    range_bearing,
    triangulate,
    triangulation_init,
    velocity,
    wrap_angle,
)

__all__ = [
    "bearing_to_inverse_depth",
    "bearing_to_point",
    "diff_drive",
    "inverse_depth_to_point",
    "inverse_range_bearing",
    "linearity_index",
    "odometry",
    "odometry_increment",
    "pi_sr_init",
    "range_bearing",
    "triangulate",
    "triangulation_init",
    "velocity",
    "wrap_angle",
]
