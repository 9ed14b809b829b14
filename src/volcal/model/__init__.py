"""The kinematic error model of a 3-axis machine: the shared core of volcal."""

from volcal.model.chain import Chain, parse_chain
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import (
    exact_pose,
    first_order_pose,
    orientation_error,
    pose_jacobian,
    volumetric_error,
    volumetric_error_exact,
)
from volcal.model.names import (
    AXES,
    COMPONENT_NAMES,
    ERROR_TABLE,
    ROLL_NAMES,
    SQUARENESS_NAMES,
    component_name,
    describe,
)

__all__ = [
    "AXES",
    "COMPONENT_NAMES",
    "ERROR_TABLE",
    "ROLL_NAMES",
    "SQUARENESS_NAMES",
    "Chain",
    "MachineErrors",
    "component_name",
    "describe",
    "exact_pose",
    "first_order_pose",
    "orientation_error",
    "parse_chain",
    "pose_jacobian",
    "volumetric_error",
    "volumetric_error_exact",
]
