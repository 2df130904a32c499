"""graspjax: a JAX-vectorized batch evaluator of plane-detection end-tool alignment for grasping.

Reproduces and extends "Automatic End Tool Alignment through Plane Detection
with a RANSAC-Algorithm for Robotic Grasping": double T-beam grasp detection
and plane-scoring re-alignment as jit/vmap kernels, evaluated in MuJoCo MJX.
"""

from graspjax.camera import Camera
from graspjax.config import AlignConfig, ConfigError, DetectorConfig, GripperConfig
from graspjax.perception import (
    Alignment,
    AlignReason,
    Grasp,
    GraspReason,
    align_tool,
    detect_grasp,
)
from graspjax.version import __version__

__all__ = ["AlignConfig", "AlignReason", "Alignment", "Camera", "ConfigError", "DetectorConfig",
           "Grasp", "GraspReason", "GripperConfig", "__version__", "align_tool", "detect_grasp"]
