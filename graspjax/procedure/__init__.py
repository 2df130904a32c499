"""The paper's grasping procedure (Fig. 1) in ONE simulated world, top to bottom.

A world plays one *round*: `start_round` places its layout, then `attempt`
is called with k = -1 (the freshly placed layout settles: the drop) and
k = 0, 1, ... (the k-th grasp attempt of the round). One attempt:

1. Overview: the tool camera looks straight down from `camera_height` over
   the workspace centre.
2. Select: the nearest point (z_min) of the workspace that stands above the
   table is the target point (`perception/target.py`). The method sees the
   depth image and what a calibrated robot knows: the camera's pose and
   intrinsics, the table plane and the workspace (Setup 3: the bin's
   interior). The attempt is credited to the object that point lies on;
   that lookup in the renderer's labels is for the record only.
3. Centre: the camera moves parallel to the table until its optical axis
   passes through that point, and looks again (`procedure.centre`: the
   paper does, "otherwise the influence of shadows increases").
4. Detect a grasp with the configured method (`Config.method`: the paper's
   double T-beam, or a baseline from `perception/baselines.py`). In every
   view the target is found again from its 3-D point alone: the visible
   point nearest to it, and the depth-connected surface around that point
   (`target.follow_target`), on which z_min is taken.
5. Re-align when none is found: the camera turns to look along the negative
   normal of the best neighbour plane, at the same distance from the plane's
   inliers, and detects again; at most `max_reorientations` times (a
   bounded loop with masks).
6. Execute and judge (`world.simulate`): the robot reaches the grasp pose off by
   the execution error (`procedure.tcp_error`, `tilt_error_deg`); a pre-grasp
   pose that would put the open hand inside a part, the bin or the table is
   refused (`COLLISION`); approach (stopped by a contact force above
   `approach_force_limit`: `COLLISION`), close, lift, hold; the lifted
   object leaves the scene, the hand returns home and the scene settles
   for the next attempt.

The protocol between attempts is the experimenter's and may use identity
(docs/method.md): in the protocol as we read the paper (a reading, docs/departures.md) each
object of a Setup 2/3 round gets one attempt, so a failed object is taken out by hand
(`procedure.remove_failed`; false leaves it where it ends up); with
`procedure.round_attempts` the round goes on until the scene is empty or
`stuck_after` attempts in a row fail. `perception.oracle` (an ablation,
never a preset) hands the method the renderer's labels of its target
instead, as graspjax did before it saw depth alone.

Every attempt ends with ONE reason code (`Reason`), computed here with this
precedence: a diverged simulation; else the physical outcome of an executed
grasp; else no target point; else a target not found again in the last view
taken (nothing to detect on, nothing to re-align around); else the alignment
failure that ended the search (no plane, or its view unreachable); else the
detection failure of the last view searched.

Its modules: `steps.py` is one attempt (the paper's Fig. 1), top to bottom; `protocol.py` the
experimenter's protocol around it (layouts, settling, who is attempted next); `state.py` what a
world carries and returns (spec, state, record, views); `truth.py` the ground truth that judges
and attributes, never decides (tests/test_procedure.py::test_the_method_decides_on_depth_alone).
Batch with `jax.vmap` at the edge (`batch/program.py`).
"""

from __future__ import annotations

from graspjax.procedure.protocol import (
    attempt_keys,
    eligible_objects,
    in_bin,
    round_goes_on,
    settle,
    start_round,
)
from graspjax.procedure.state import PlaneTruth, Record, RoundState, TargetClutter, Views, WorldSpec
from graspjax.procedure.steps import (
    attempt,
    centred_pose,
    first_look,
    overview_pose,
    select_target,
    view,
    view_keys,
)
from graspjax.procedure.truth import plane_truth, target_faces, target_pixels, with_oracle

__all__ = [
    "PlaneTruth", "Record", "RoundState", "TargetClutter", "Views", "WorldSpec", "attempt",
    "attempt_keys", "centred_pose", "eligible_objects", "first_look", "in_bin", "overview_pose",
    "plane_truth", "round_goes_on", "select_target", "settle", "start_round", "target_faces",
    "target_pixels", "view", "view_keys", "with_oracle",
]


