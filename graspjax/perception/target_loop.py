"""Step 5 of `detect_real_image` (`real_image.py`) for ONE image: its targets tried in order of
height, each in its own detection window, until `top_k` distinct grasps passed.

Target k is the best candidate outside the surfaces already tried. The grasp method runs in
its window at the detection resolution; its `candidates_per_target` most central placements
are checked on the image's height map (`jaws.check_jaws_where`) and scored
(`jaws.grasp_score`); with `image.contour_search`, a target none of whose placements passed
gets antipodal pairs along its band's and its followed surface's contours, checked the same
way. A target given up gives up its followed surface, not only its band. Everything checked
is pooled (`Pool`), and the loop carries the detector's result and window of the best
target so far (`Best`), where the tool is aligned.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import lax

from graspjax.camera import Camera
from graspjax.codes import GraspReason
from graspjax.config import Config, RealImageConfig
from graspjax.perception.baselines import antipodal_grasp, evenly_spread, grasp_method
from graspjax.perception.cluster import target_surface
from graspjax.perception.jaws import HeightMap, JawCheck, check_placements_at, grasp_score
from graspjax.perception.placements import Grasp
from graspjax.perception.ranking import distinct_best
from graspjax.perception.reasons import further_reason, furthest_reason
from graspjax.perception.support import SupportPlane
from graspjax.perception.target import best_candidate
from graspjax.perception.window import detection_window, followed_surface, surface_in_view
from graspjax.tree import concat_trees, where_tree


class Placements(NamedTuple):
    """Placements checked on the jaws' height map, leading axis P (`per` of one target; the pool's
    `max_targets * per`); `placed` is None once pooled."""

    passed: jax.Array  # (P,) bool: placed and every jaws' check passed
    score: jax.Array  # (P,) `grasp_score` where passed, -inf elsewhere
    target: jax.Array  # (P,) int32 the target it stands on (k)
    index: jax.Array  # (P,) int32 its placement in that target's `Grasp.candidates`
    contour: jax.Array  # (P,) bool: placed by the contour search
    position: jax.Array  # (P, 3) grasp centre, camera frame
    axis: jax.Array  # (P, 3) closing axis, camera frame
    width: jax.Array  # (P,) width of the gripped band (m)
    distance: jax.Array  # (P,) distance from the part's centre across the view (m)
    jaws: JawCheck  # the jaws' checks, leading axis P
    placed: jax.Array | None  # (P,) bool: a valid placement of a target that was found


class Tried(NamedTuple):
    """What one target came to, leading axis `max_targets` in the pool."""

    reason: jax.Array  # () int32 its `GraspReason` (-1 in the pool: not tried)
    pixel: jax.Array  # (2,) int32 its pixel in the support view (u, v)
    point: jax.Array  # (3,) its point, view frame
    found: jax.Array  # () bool: there was a target to try


class Pool(NamedTuple):
    """Every target's checked placements and outcome."""

    placements: Placements  # leading axis max_targets * per (`placed` None)
    tried: Tried  # leading axis max_targets


class Window(NamedTuple):
    """A target's detection window: where the tool is aligned if it is the best target."""

    depth: jax.Array  # (S, S) detection-resolution depth (0 = invalid)
    camera: Camera  # its intrinsics (view frame)
    seed: jax.Array  # (S, S) bool: the target's followed surface in it


class Best(NamedTuple):
    """The best target so far (the last one while none passed)."""

    score: jax.Array  # () its best placement's score (-inf: none passed)
    k: jax.Array  # () int32 its index
    grasp: Grasp  # the detector's result in its window
    window: Window


class Loop(NamedTuple):
    """The loop's carry."""

    k: jax.Array  # () int32 targets tried
    covered: jax.Array  # (h, w) bool: support-view pixels of the surfaces tried
    pool: Pool
    best: Best


@dataclasses.dataclass(frozen=True, eq=False)  # hashed by identity: its fields are traced
class TargetSearch:
    """One image's constants for the loop (`detect_real_image` builds it), and its steps."""

    config: Config
    image: RealImageConfig
    heights: HeightMap  # the scene along the view's approach, workspace or not: the jaws' checks
    fine: jax.Array  # (H', W') detection-resolution depth
    fine_slope: jax.Array  # (H', W') its surfaces' slope against the view
    fine_camera: Camera  # its intrinsics
    fine_view: Camera  # the (virtual) view's intrinsics at the detection resolution
    rotation: jax.Array  # (3, 3) view-to-camera rotation
    support: SupportPlane  # the support plane, view frame
    depth: jax.Array  # (h, w) the view's depth at the support resolution
    valid: jax.Array  # (h, w) bool: its pixels with depth
    points: jax.Array  # (h, w, 3) its points, view frame
    candidate: jax.Array  # (h, w) bool target candidates
    score: jax.Array  # (h, w) their order of preference
    window_config: Config  # the window's own checks (the wall is judged on the height map)

    @property
    def per(self) -> int:
        return self.image.candidates_per_target

    def checked(self, cands, found, centre, k, first, by_contour) -> Placements:
        """`per` valid placements of `cands` (a `TBeams`) checked on the jaws' height map (the
        method's nearest the part's `centre` (3,), the contour search's spread along the
        contour): target k's, indexed in its candidates from `first`."""
        per, rotation = self.per, self.rotation
        offset = jnp.linalg.norm(cands.center[:, :2] - centre[:2], axis=-1)
        if by_contour:
            index, real = evenly_spread(cands.valid, per)
        else:
            count = min(per, cands.valid.shape[0])  # a baseline may propose fewer placements
            _, index = lax.top_k(-jnp.where(cands.valid, offset, jnp.inf), count)
            index, real = jnp.pad(index, (0, per - count)), jnp.arange(per) < count
        placed = cands.valid[index] & found & real
        position = cands.center[index] @ rotation.T
        axis = jnp.pad(cands.axis[index], ((0, 0), (0, 1))) @ rotation.T
        jaws = check_placements_at(placed, self.heights, cands, index, self.config.detect,
                                   self.config.gripper, self.image)
        passed = placed & (jaws.reason == GraspReason.FOUND)
        rank = jnp.where(passed, grasp_score(jaws, cands.width[index], offset[index],
                                             self.config.detect, self.config.gripper, self.image),
                         -jnp.inf)
        return Placements(passed=passed, score=rank, target=jnp.full(per, k, jnp.int32),
                          index=(index + first).astype(jnp.int32),
                          contour=jnp.full(per, by_contour), position=position, axis=axis,
                          width=cands.width[index], distance=offset[index], jaws=jaws,
                          placed=placed)

    @staticmethod
    def outcome(placements: Placements, window_reason) -> jax.Array:
        """A target's `GraspReason` from its checked placements: FOUND if one passed, else the
        furthest stage the placed ones reached in the jaws' checks, else the window's reason."""
        placed = placements.placed
        failed = jnp.where(jnp.any(placed), furthest_reason(placements.jaws.reason, placed),
                           window_reason)
        return jnp.where(jnp.any(placements.passed), GraspReason.FOUND, failed).astype(jnp.int32)

    def contour_search(self, window: Window, grasp: Grasp, centre, k, found):
        """Antipodal pairs on the band's contour and on the followed surface's (a top sloping
        past the band's depth: the part's outline); `per` of each checked, the `per` best
        distinct kept (the two propose the same pairs where the band is the surface): their
        candidates, the kept placements and their reason."""
        per, config = self.per, self.config
        first = grasp.candidates.valid.shape[0]
        searches = [antipodal_grasp(window.depth, window.camera, self.window_config.detect,
                                    config.gripper, config.baseline, window.seed & found,
                                    surface=outline)
                    for outline in (None, window.seed & found)]
        both = concat_trees(*[
            self.checked(pairs.candidates, pairs.found & found, centre, k,
                         first + i * pairs.candidates.valid.shape[0], True)
            for i, pairs in enumerate(searches)])
        reason = self.outcome(both, further_reason(*[pairs.reason for pairs in searches]))
        best, distinct = distinct_best(both.passed, both.score, both.position, both.axis, per,
                                       self.image.duplicate_distance)
        kept = jax.tree.map(lambda x: x[jnp.clip(best, 0)], both)
        kept = kept._replace(passed=distinct, score=jnp.where(distinct, kept.score, -jnp.inf))
        candidates = concat_trees(*[pairs.candidates for pairs in searches])
        return candidates, kept, reason

    def no_contour_search(self, window: Window, grasp: Grasp, centre, k, found):
        """`contour_search`'s shapes where it does not run: no placement, every one refused."""
        pairs, searched, _ = jax.tree.map(jnp.zeros_like, jax.eval_shape(
            self.contour_search, window, grasp, centre, k, found))
        no = jnp.int32(GraspReason.NO_ANTIPODAL)
        return (dataclasses.replace(pairs, reason=jnp.full_like(pairs.reason, no)),
                searched._replace(score=jnp.full(self.per, -jnp.inf)), no)

    def examine(self, k, covered):
        """Target k: the surfaces tried after it, its checked placements (`per`, `placed`
        None), what it came to, its detector result and its window."""
        config, image = self.config, self.image
        chosen, pixel = best_candidate(self.candidate & ~covered, self.score)
        found = jnp.any(chosen)
        point = jnp.where(found, self.points[pixel[1], pixel[0]], 0.0)  # view frame
        depth, slope, camera = detection_window(self.fine, self.fine_slope, self.fine_camera,
                                                self.fine_view, self.rotation, point,
                                                image.crop_px)
        seed = followed_surface(depth, slope, camera, point, self.support, config,
                                image.max_target_slope_deg)
        window = Window(depth, camera, seed)
        grasp = grasp_method(config.method)(depth, camera, self.window_config, seed & found)
        surface, _ = target_surface(self.depth, self.valid & found, pixel,
                                    self.depth[pixel[1], pixel[0]],
                                    config.detect.surface_tolerance,
                                    unroll=config.detect.unrolled_loops)
        centre = (jnp.sum(self.points * surface[..., None], (0, 1))
                  / jnp.maximum(jnp.sum(surface), 1))

        # Its most central valid placements checked on the jaws' height map; if none passes, with
        # `image.contour_search` its contour's antipodal pairs too (the further reason wins).
        placements = self.checked(grasp.candidates, grasp.found & found, centre, k, 0, False)
        reason = self.outcome(placements, grasp.reason)
        if image.contour_search and config.method == "paper":
            pairs, searched, searched_reason = lax.cond(
                ~jnp.any(placements.passed) & found, self.contour_search, self.no_contour_search,
                window, grasp, centre, k, found)
            rescued = jnp.any(searched.passed)
            placements = where_tree(rescued, searched, placements)
            reason = further_reason(reason, searched_reason)  # skipped: NO_ANTIPODAL
            grasp = dataclasses.replace(grasp, candidates=concat_trees(grasp.candidates, pairs))
        # A target given up gives up its object: its followed surface in the window (with the
        # contour search, the outline it paired across), not only its band, is tried.
        given_up = lax.cond(found & ~jnp.any(placements.passed),
                            lambda: surface_in_view(seed, camera, self.points, self.valid,
                                                    self.fine.shape[1] // self.depth.shape[1]),
                            lambda: jnp.zeros_like(self.valid))
        return (covered | surface | chosen | given_up, placements._replace(placed=None),
                Tried(reason=reason, pixel=pixel, point=point, found=found), grasp,
                window._replace(seed=seed & found))

    def step(self, loop: Loop) -> Loop:
        """Target `loop.k` tried: its placements and outcome pooled, the best target kept
        (ties keep the first)."""
        k, per = loop.k, self.per
        covered, placements, tried, grasp, window = self.examine(k, loop.covered)
        pool = Pool(
            placements=jax.tree.map(
                lambda whole, part: lax.dynamic_update_slice_in_dim(whole, part, k * per, 0),
                loop.pool.placements, placements),
            tried=jax.tree.map(lambda whole, part: whole.at[k].set(part), loop.pool.tried,
                               tried))
        best = loop.best
        own_score = jnp.max(placements.score)
        better = (own_score > best.score) | (best.score == -jnp.inf)
        best = Best(jnp.where(better, own_score, best.score), jnp.where(better, k, best.k),
                    *where_tree(better, (grasp, window), (best.grasp, best.window)))
        return Loop(k + 1, covered, pool, best)

    def distinct(self, pool: Pool):
        """The pool's best `top_k` distinct passed placements (`ranking.distinct_best`)."""
        p = pool.placements
        return distinct_best(p.passed, p.score, p.position, p.axis, self.image.top_k,
                             self.image.duplicate_distance)

    def more(self, loop: Loop) -> jax.Array:
        """Another target is tried: the first always (its window is the one reported when no
        target is found), then while fewer than `max_targets` so far, candidates left and
        fewer than `top_k` distinct grasps passed."""
        return (loop.k == 0) | (
            (loop.k < self.image.max_targets) & jnp.any(self.candidate & ~loop.covered)
            & (jnp.sum(self.distinct(loop.pool)[1]) < self.image.top_k))

    def run(self) -> Loop:
        """Every target tried (at least the first, at most `max_targets`)."""
        n, per = self.image.max_targets, self.per
        nothing = jnp.zeros(self.candidate.shape, bool)
        _, placements, tried, grasp, window = jax.eval_shape(self.examine, 0, nothing)
        empty = Pool(
            placements=jax.tree.map(lambda x: jnp.zeros((n * per, *x.shape[1:]), x.dtype),
                                    placements)._replace(score=jnp.full(n * per, -jnp.inf,
                                                                        jnp.float32)),
            tried=jax.tree.map(lambda x: jnp.zeros((n, *x.shape), x.dtype),
                               tried)._replace(reason=jnp.full(n, -1, jnp.int32)))
        best = Best(jnp.float32(-jnp.inf), jnp.int32(0),
                    *jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), (grasp, window)))
        return lax.while_loop(self.more, self.step, Loop(jnp.int32(0), nothing, empty, best))
