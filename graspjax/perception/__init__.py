"""Perception kernels: grasp detection (paper 3.1) and end-tool alignment (paper 3.2).

Each kernel is written for ONE depth image `(H, W)`; batch with `jax.vmap`.
"""

from graspjax.perception.align import Alignment, align_tool, plane_inliers
from graspjax.perception.grasp import Grasp, TBeams, detect_grasp
from graspjax.perception.reasons import AlignReason, GraspReason

__all__ = ["Alignment", "AlignReason", "Grasp", "GraspReason", "TBeams", "align_tool",
           "detect_grasp", "plane_inliers"]
