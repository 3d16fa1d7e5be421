"""Rigid-body geometry: SO(3) and SE(3) as plain numpy functions (batched where it matters)."""
from .so3 import exp_so3, log_so3, hat, rotation_angle_deg, is_rotation, project_to_so3, random_rotation
from .se3 import (make_T, inv_T, compose, exp_se3, log_se3, interpolate_T, transform_points,
                  perturb_T, adjoint)

__all__ = ["exp_so3", "log_so3", "hat", "rotation_angle_deg", "is_rotation", "project_to_so3",
           "random_rotation", "make_T", "inv_T", "compose", "exp_se3", "log_se3", "interpolate_T",
           "transform_points", "perturb_T", "adjoint"]
