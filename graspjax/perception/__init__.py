"""Perception kernels: grasp detection (paper 3.1) and end-tool alignment (paper 3.2).

Each kernel is written for ONE depth image `(H, W)`; batch with `jax.vmap`.
"""

from graspjax.codes import AlignReason, GraspReason
from graspjax.perception.align import Alignment, align_tool, plane_inliers
from graspjax.perception.grasp import detect_grasp
from graspjax.perception.placements import Grasp, TBeams

__all__ = ["Alignment", "AlignReason", "Grasp", "GraspReason", "TBeams", "align_tool",
           "detect_grasp", "plane_inliers"]
