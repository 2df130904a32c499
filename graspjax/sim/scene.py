"""Scene models: a table, a set of objects, four walls (the bin of Setup 3's variant), and a floating
parallel-jaw gripper.

One compiled model serves every layout of its objects: an object that is not
in the current layout is *parked*, at rest in the air far from the workspace
with gravity compensated (`world.physics_model` sets its `body_gravcomp` per
world), so it makes no contacts and adds no constraint to the solver. The
a-f scene with object-object contacts and four walls serves Setups 2 and 3
(each wall is a mocap body: in Setup 3's bin variant they stand around the
pile as the bin, and wait far away otherwise); scenes without them (one object at a time, fewer contact slots)
serve Setup 1.

The gripper is a free-floating hand (gravity compensated, as a robot arm's
controller does) welded to a mocap target, so it follows any 6-D pose. Its
palm has the size of a Franka Hand's (the MuJoCo Menagerie model's collision
capsule: 20 cm along the closing axis, 8 cm across) with a wrist camera
housing (an Intel RealSense D435's 9 x 2.5 x 2.5 cm) on its side. Two
slide-joint box fingers are coupled by a joint equality and driven by one
position servo whose force is limited to twice `grip_force` (each finger
then presses with `grip_force`; the coupling carries the other half). In
the hand frame, z points from the palm to the finger tips (the approach
direction) and x is the closing axis.
"""

from __future__ import annotations

import dataclasses

import jax
import mujoco
import numpy as np

from graspjax.config import MAX_WALL_HEIGHT, GripperConfig, LayoutConfig, SimConfig
from graspjax.privates import quiet_import
from graspjax.sim.objects import OBJECTS, object_mjcf, resting_poses_of
from graspjax.sim.physics import HAND, STATIC
from graspjax.sim.raycast import Solids, solids_of

mjx = quiet_import("mujoco.mjx")  # mjx prints that its optional backends are missing

# Contact bits: a geom pair collides when contype of one matches conaffinity of the other.
_TABLE, _OBJECT, _GRIPPER = 1, 2, 4
PARK_HEIGHT = 1.0  # parked objects hang this high above the table (m), far outside the view
_PARK_X = 3.0  # first parking spot (m); objects park 0.5 m apart along x
WALL_PARK = np.array([-3.0, 0.0, 0.0])  # where the walls wait when not around a pile (m)
GRIPPER_HOME = np.array([0.0, 0.0, 1.5])  # the gripper waits here, above the camera's view
PALM_HALF = np.array([0.10, 0.04, 0.03])  # palm half extents (m): a Franka Hand's envelope
HOUSING_HALF = np.array([0.045, 0.0125, 0.0125])  # wrist camera housing half extents (m)
CLOSED_TARGET = -0.01  # servo target of closed jaws, beyond touching: the force limit decides (m)
PAD_TIMECONST = 0.01  # contact time constant of the hand's geoms (s): stiff pads, 2 steps


@dataclasses.dataclass(frozen=True, eq=False)  # hashed by identity: usable as a static jit argument
class Scene:
    """A compiled scene and the indices the simulation needs (shared by all worlds)."""

    letters: tuple[str, ...]  # objects in the model, in body order
    mj_model: mujoco.MjModel
    model: mjx.Model
    object_body: np.ndarray  # (n,) body id of each object
    object_qpos: np.ndarray  # (n,) qpos address of each object's free joint
    object_qvel: np.ndarray  # (n,) qvel address of each object's free joint
    park_pos: np.ndarray  # (n, 3) parking position of each object
    has_walls: bool  # the scene holds the four walls of the bin
    wall_mocap: np.ndarray  # (4,) mocap indices of the walls at +x, -x, +y, -y (empty without)
    wall_thickness: float  # the walls' thickness (m)
    hand_mocap: int  # mocap index of the hand's target
    hand_qpos: int  # qpos address of the hand's free joint
    hand_qvel: int
    finger_qpos: np.ndarray  # (2,) qpos addresses of the two finger slides
    finger_qvel: np.ndarray
    gripper_geom: np.ndarray  # (ngeom,) bool: palm, housing and fingers (their friction: the pads')
    geom_object: np.ndarray  # (ngeom,) int32 object index of each geom, -1 for others
    hand_points: np.ndarray  # (P, 3) corners and face centres of the open hand's boxes, hand frame
    finger_points: np.ndarray  # (F, 3) the same of the open fingers alone, hand frame
    tcp_offset: float  # hand-frame z of the point between the finger tips (m)
    object_com: np.ndarray  # (n, 3) centre of mass of each object in its frame (m)
    object_points: np.ndarray  # (n, V, 3) piece vertices in the object frame, padded by repeats
    resting: np.ndarray  # (n, R, 3, 3) rotations in which drops of each object came to rest
    solids: Solids  # half-spaces of the table, the walls and every object piece
    piece_object: np.ndarray  # (G,) object index of each rendered piece, -1 for table and walls
    gripper: GripperConfig
    sim: SimConfig

    @property
    def num_objects(self) -> int:
        return len(self.letters)

    @property
    def skips_far_pairs(self) -> bool:
        """Whether the physics step skips the narrow phase of pairs far apart in every world
        (`sim.skip_far_pairs`, in scenes whose objects do not touch each other: in piles the
        hand's pairs are the only ones to skip, a few per cent of a step for a much longer
        compile)."""
        return self.sim.skip_far_pairs and not self.has_walls

    @property
    def geom_owner(self) -> np.ndarray:
        """Who owns each geom (ngeom,) int: STATIC (table, walls), HAND or the object index; the
        physics step's broad phase skips pairs by owner (`collision.parts`)."""
        return np.where(self.gripper_geom, HAND, np.where(self.geom_object >= 0, self.geom_object,
                                                          STATIC)).astype(np.int32)


def _box_points(half: np.ndarray, centre) -> np.ndarray:
    """Corners, edge midpoints and face centres (26, 3) of a box."""
    grid = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)
                     if (x, y, z) != (0, 0, 0)], float)
    return grid * half + np.asarray(centre, float)


WALL_SIDES = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])  # each wall's outward normal


def _walls_mjcf(layout: LayoutConfig) -> str:
    """Four mocap bodies, one wall each (+x, -x, +y, -y), parked. Each wall is
    `MAX_WALL_HEIGHT` tall: a lower bin sinks it into the table (`pile.place_walls`)."""
    half_length, half_thickness = layout.wall_length / 2, layout.wall_thickness / 2
    park = " ".join(f"{v:g}" for v in WALL_PARK)
    bodies = []
    for k, (nx, _) in enumerate(WALL_SIDES):
        hx, hy = (half_thickness, half_length) if nx else (half_length, half_thickness)
        bodies.append(
            f'<body name="wall_{k}" mocap="true" pos="{park}"><geom name="wall_{k}" type="box" '
            f'size="{hx:g} {hy:g} {MAX_WALL_HEIGHT / 2:g}" contype="{_TABLE}" '
            f'conaffinity="{_OBJECT | _GRIPPER}" material="default"/></body>')
    return "\n".join(bodies)


def scene_mjcf(letters, gripper: GripperConfig, sim: SimConfig, objects_collide: bool,
               layout: LayoutConfig = LayoutConfig()) -> str:
    """The MJCF text of a scene with the given objects (and the walls when objects collide)."""
    friction = f"{sim.object_friction:g} 0.005 0.0001"
    contacts = sim.max_contact_points if objects_collide else sim.max_contact_points_alone
    object_affinity = _TABLE | _GRIPPER | (_OBJECT if objects_collide else 0)
    pairs = (f'<numeric name="max_geom_pairs" data="{sim.max_geom_pairs}"/>'
             if sim.max_geom_pairs else "")
    assets, bodies = [], []
    for i, letter in enumerate(letters):
        asset, geoms = object_mjcf(OBJECTS[letter], prefix="obj_")
        assets.append(asset)
        park = (_PARK_X + 0.5 * i, 0.0, PARK_HEIGHT)
        bodies.append(f'<body name="obj_{letter}" pos="{park[0]:g} {park[1]:g} {park[2]:g}">'
                      f'<freejoint name="obj_{letter}"/>\n{geoms}\n</body>')
    g = gripper
    finger_z = PALM_HALF[2] + g.finger_length / 2
    finger_size = f"{g.finger_thickness / 2:g} {g.finger_width / 2:g} {g.finger_length / 2:g}"
    housing_pos = f"0 {PALM_HALF[1] + HOUSING_HALF[1]:g} {PALM_HALF[2] - HOUSING_HALF[2]:g}"
    home = " ".join(f"{v:g}" for v in GRIPPER_HOME)
    return f"""<mujoco model="graspjax_{''.join(letters)}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{sim.timestep:g}" iterations="{sim.iterations}" ls_iterations="{sim.ls_iterations}"
          cone="{sim.cone}" impratio="{sim.impratio:g}">
    <flag eulerdamp="disable"/>
  </option>
  <custom><numeric name="max_contact_points" data="{contacts}"/>{pairs}</custom>
  <default>
    <geom condim="{sim.condim}" friction="{friction}" contype="{_OBJECT}" conaffinity="{object_affinity}"/>
    <default class="gripper">
      <geom contype="{_GRIPPER}" conaffinity="{_TABLE | _OBJECT}"
            friction="{g.friction:g} 0.005 0.0001" solref="{PAD_TIMECONST:g} 1"/>
      <joint type="slide" range="0 {g.opening / 2:g}" armature="{sim.finger_armature:g}"
             damping="{sim.finger_damping:g}"/>
    </default>
  </default>
  <asset>
    <material name="default" rgba="0.8 0.8 0.8 1"/>
{chr(10).join(assets)}
  </asset>
  <worldbody>
    <geom name="table" type="plane" size="0 0 1" contype="{_TABLE}" conaffinity="{_OBJECT | _GRIPPER}"
          material="default"/>
{_walls_mjcf(layout) if objects_collide else ""}
{chr(10).join(bodies)}
    <body name="gripper_target" mocap="true" pos="{home}"/>
    <body name="hand" pos="{home}" gravcomp="1">
      <freejoint name="hand"/>
      <geom name="palm" class="gripper" type="box" size="{PALM_HALF[0]:g} {PALM_HALF[1]:g} {PALM_HALF[2]:g}"
            mass="{sim.hand_mass:g}"/>
      <geom name="housing" class="gripper" type="box"
            size="{HOUSING_HALF[0]:g} {HOUSING_HALF[1]:g} {HOUSING_HALF[2]:g}" pos="{housing_pos}"
            mass="0"/>
      <body name="finger_1" pos="0 0 {finger_z:g}" gravcomp="1">
        <joint name="finger_1" class="gripper" axis="1 0 0"/>
        <geom name="finger_1" class="gripper" type="box" size="{finger_size}"
              pos="{g.finger_thickness / 2:g} 0 0" mass="{sim.finger_mass:g}"/>
      </body>
      <body name="finger_2" pos="0 0 {finger_z:g}" gravcomp="1">
        <joint name="finger_2" class="gripper" axis="-1 0 0"/>
        <geom name="finger_2" class="gripper" type="box" size="{finger_size}"
              pos="{-g.finger_thickness / 2:g} 0 0" mass="{sim.finger_mass:g}"/>
      </body>
    </body>
  </worldbody>
  <contact><exclude body1="finger_1" body2="finger_2"/></contact>
  <equality>
    <weld name="grip" body1="gripper_target" body2="hand" solref="{sim.grip_timeconst:g} 1"/>
    <joint joint1="finger_1" joint2="finger_2" solref="{2 * sim.timestep:g} 1"/>
  </equality>
  <actuator>
    <position name="jaws" joint="finger_1" kp="{sim.finger_kp:g}"
              ctrlrange="{CLOSED_TARGET:g} {g.opening / 2:g}"
              forcerange="{-2 * g.grip_force:g} {2 * g.grip_force:g}"/>
  </actuator>
</mujoco>
"""


_SCENES: dict = {}


def scene_for(letters, config, objects_collide: bool) -> Scene:
    """The shared compiled scene of these objects under `config`'s static values.

    Traced values (frictions, grip force) do not change the model: worlds set
    them with `world.physics_model`, so every sweep point shares one scene.
    """
    key = (tuple(letters), jax.tree.structure(config.gripper), jax.tree.structure(config.sim),
           jax.tree.structure(config.layout), bool(objects_collide))
    if key not in _SCENES:
        _SCENES[key] = build_scene(letters, config.gripper, config.sim, objects_collide,
                                   config.layout)
    return _SCENES[key]


def build_scene(letters, gripper: GripperConfig = GripperConfig(), sim: SimConfig = SimConfig(),
                objects_collide: bool = True, layout: LayoutConfig = LayoutConfig()) -> Scene:
    """Compile a scene of the given object letters (one MJX model for all layouts)."""
    letters = tuple(letters)
    mj_model = mujoco.MjModel.from_xml_string(
        scene_mjcf(letters, gripper, sim, objects_collide, layout))
    def obj_id(kind, name):
        return mujoco.mj_name2id(mj_model, kind, name)

    bodies = np.array([obj_id(mujoco.mjtObj.mjOBJ_BODY, f"obj_{c}") for c in letters])
    joints = np.array([obj_id(mujoco.mjtObj.mjOBJ_JOINT, f"obj_{c}") for c in letters])
    hand = obj_id(mujoco.mjtObj.mjOBJ_JOINT, "hand")
    fingers = np.array([obj_id(mujoco.mjtObj.mjOBJ_JOINT, f"finger_{k}") for k in (1, 2)])
    hand_body = int(mj_model.jnt_bodyid[hand])
    finger_bodies = [int(b) for b in mj_model.jnt_bodyid[fingers]]
    walls = range(len(WALL_SIDES)) if objects_collide else ()
    wall_geoms = [obj_id(mujoco.mjtObj.mjOBJ_GEOM, f"wall_{k}") for k in walls]
    statics = [obj_id(mujoco.mjtObj.mjOBJ_GEOM, "table"), *wall_geoms]
    object_geoms = [g for g in range(mj_model.ngeom) if mj_model.geom_bodyid[g] in bodies]
    geom_object = np.full(mj_model.ngeom, -1, np.int32)
    for g in object_geoms:
        geom_object[g] = int(np.flatnonzero(bodies == mj_model.geom_bodyid[g])[0])
    points = [OBJECTS[c].points() for c in letters]
    most = max(len(p) for p in points)
    padded = np.stack([np.concatenate([p, np.repeat(p[:1], most - len(p), 0)]) for p in points])
    opened = gripper.opening / 2 + gripper.finger_thickness / 2
    finger_half = np.array([gripper.finger_thickness, gripper.finger_width,
                            gripper.finger_length]) / 2
    finger_z = PALM_HALF[2] + gripper.finger_length / 2
    finger_points = np.concatenate([_box_points(finger_half, (opened, 0, finger_z)),
                                    _box_points(finger_half, (-opened, 0, finger_z))])
    hand_points = np.concatenate([
        _box_points(PALM_HALF, (0, 0, 0)),
        _box_points(HOUSING_HALF, (0, PALM_HALF[1] + HOUSING_HALF[1], PALM_HALF[2] - HOUSING_HALF[2])),
        finger_points])
    return Scene(
        letters=letters,
        mj_model=mj_model,
        model=mjx.put_model(mj_model, device=jax.local_devices()[0]),  # not another process's
        object_body=bodies,
        object_qpos=mj_model.jnt_qposadr[joints],
        object_qvel=mj_model.jnt_dofadr[joints],
        park_pos=mj_model.body_pos[bodies].copy(),
        has_walls=bool(objects_collide),
        wall_mocap=np.array([mj_model.body_mocapid[obj_id(mujoco.mjtObj.mjOBJ_BODY, f"wall_{k}")]
                             for k in walls], np.int32),
        wall_thickness=layout.wall_thickness,
        hand_mocap=int(mj_model.body_mocapid[obj_id(mujoco.mjtObj.mjOBJ_BODY, "gripper_target")]),
        hand_qpos=int(mj_model.jnt_qposadr[hand]),
        hand_qvel=int(mj_model.jnt_dofadr[hand]),
        finger_qpos=mj_model.jnt_qposadr[fingers],
        finger_qvel=mj_model.jnt_dofadr[fingers],
        gripper_geom=np.isin(mj_model.geom_bodyid, [hand_body, *finger_bodies]),
        geom_object=geom_object,
        hand_points=hand_points,
        finger_points=finger_points,
        tcp_offset=float(PALM_HALF[2] + gripper.finger_length),
        object_com=mj_model.body_ipos[bodies].copy(),
        object_points=padded,
        resting=resting_poses_of(letters),
        solids=solids_of(mj_model, statics + object_geoms),
        piece_object=np.array([-1] * len(statics) + [int(geom_object[g]) for g in object_geoms],
                              np.int32),
        gripper=gripper,
        sim=sim,
    )
