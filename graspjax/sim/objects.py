"""Objects a-l: our own parametric shapes made of convex pieces.

a-f are basic geometries (paper: "self-created objects"); g-l stand for the
industrial and everyday parts of the Sileane / Fraunhofer IPA bin-picking
sets used by the paper, rebuilt from their rough dimensions and scaled to
fit the default gripper (8 cm opening), as the paper scaled its own.

Every object is defined in its resting pose: z up, base on z = 0, centred in
x and y. Pieces are boxes (cheap in MuJoCo, and every box pair shares one
collision function in MJX) or convex hulls of at most 32 vertices (round
parts are regular n-gon prisms, n <= 16). The physics, the depth renderer and
the exported assets all use these same pieces, so what the camera sees is
what the gripper touches.

`python -m graspjax.sim.objects assets/objects` writes, per object, an MJCF
model and an OBJ mesh, and `catalogue.csv` with sizes, masses and pieces.
"""

from __future__ import annotations

import concurrent.futures
import csv
import dataclasses
import functools
import hashlib
import io
import math
import platform
from pathlib import Path

import numpy as np

from graspjax.runtime.stores import keep, store


@dataclasses.dataclass(frozen=True)
class Piece:
    """One convex piece in the object frame: a box or the convex hull of vertices."""

    kind: str  # "box" or "hull"
    half_size: tuple[float, float, float] = (0.0, 0.0, 0.0)  # box half extents (m)
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)  # box centre (m)
    yaw: float = 0.0  # box rotation about z (rad)
    vertices: tuple[tuple[float, float, float], ...] = ()  # hull vertices (m)

    def points(self) -> np.ndarray:
        """Corner or hull vertices `(N, 3)` in the object frame."""
        if self.kind == "hull":
            return np.asarray(self.vertices, float)
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        return (signs * self.half_size) @ rot.T + self.pos


@dataclasses.dataclass(frozen=True)
class ObjectSpec:
    """A test object: letter, name, what it stands for, material density and pieces."""

    letter: str
    name: str
    stands_for: str
    density: float  # kg / m^3
    pieces: tuple[Piece, ...]

    def points(self) -> np.ndarray:
        """All piece vertices `(N, 3)` in the object frame."""
        return np.concatenate([p.points() for p in self.pieces])

    @property
    def size(self) -> np.ndarray:
        """Bounding-box extents (x, y, z) in the resting pose (m)."""
        pts = self.points()
        return pts.max(0) - pts.min(0)


def _box(half, pos, yaw: float = 0.0) -> Piece:
    return Piece("box", half_size=tuple(map(float, half)), pos=tuple(map(float, pos)), yaw=yaw)


def _hull(points) -> Piece:
    pts = np.asarray(points, float)
    if len(pts) > 32:
        raise ValueError("hull pieces keep at most 32 vertices (MJX convex collision cost)")
    return Piece("hull", vertices=tuple(map(tuple, np.round(pts, 6))))


def _prism(sides: int, radius: float, z0: float, z1: float, axis: str = "z",
           centre=(0.0, 0.0, 0.0), flat_down: bool = False) -> Piece:
    """Regular n-gon prism between z0 and z1 along `axis` (circumradius `radius`).

    flat_down: for a horizontal axis, rotate so a face (not an edge) points down.
    """
    phase = math.pi / sides if flat_down else 0.0
    angle = phase + 2 * math.pi * np.arange(sides) / sides
    ring = np.stack([radius * np.cos(angle), radius * np.sin(angle)], 1)
    pts = []
    for z in (z0, z1):
        for a, b in ring:
            if axis == "z":
                pts.append((a, b, z))
            else:  # along x: the polygon lies in the y-z plane, "down" is -z
                pts.append((z, b, -a) if flat_down else (z, a, b))
    return _hull(np.asarray(pts) + centre)


def _ring(sides: int, radius: float, wall: float, z0: float, z1: float) -> tuple[Piece, ...]:
    """A thin upright wall around z: `sides` boxes of thickness `wall` centred on `radius`."""
    half_side = radius * math.tan(math.pi / sides) + wall / 2  # the boxes meet at the corners
    return tuple(_box((wall / 2, half_side, (z1 - z0) / 2),
                      (radius * math.cos(a), radius * math.sin(a), (z0 + z1) / 2), a)
                 for a in 2 * math.pi * np.arange(sides) / sides)


def _extrude_xz(profile, y0: float, y1: float) -> Piece:
    """Convex polygon in the x-z plane extruded along y."""
    return _hull([(x, y, z) for y in (y0, y1) for x, z in profile])


def _catalogue() -> dict[str, ObjectSpec]:
    s = 0.055  # triangular prism side
    hexagon_r = 0.045 / math.sqrt(3)  # 4.5 cm across flats
    gear_r, tooth = 0.024, (0.0045, 0.004, 0.0075)
    ring_r, tube = 0.020, 0.005
    cup_wall = 0.003
    ring_side = 2 * ring_r * math.tan(math.pi / 8)
    shaft_axis = 0.022 * math.cos(math.pi / 16)
    objects = [
        ObjectSpec("a", "cube", "basic geometry: 5 cm cube", 700.0,
                   (_box((0.025, 0.025, 0.025), (0, 0, 0.025)),)),
        ObjectSpec("b", "triangular_prism", "basic geometry: equilateral prism lying on a side",
                   700.0, (_extrude_xz([(-s / 2, 0), (s / 2, 0), (0, s * math.sqrt(3) / 2)],
                                       -0.04, 0.04),)),
        ObjectSpec("c", "wedge", "basic geometry: ramp with a 25 degree top face", 700.0,
                   (_extrude_xz([(-0.0325, 0), (0.0325, 0), (0.0325, 0.04), (-0.0325, 0.01)],
                                -0.025, 0.025),)),
        ObjectSpec("d", "hexagonal_prism", "basic geometry: hexagonal prism (4.5 cm across flats)",
                   700.0, (_prism(6, hexagon_r, 0.0, 0.04),)),
        ObjectSpec("e", "cylinder", "basic geometry: upright cylinder (16-gon, 5 cm diameter)",
                   700.0, (_prism(16, 0.025, 0.0, 0.07),)),
        ObjectSpec("f", "block", "basic geometry: flat block 7 x 4 x 3 cm", 700.0,
                   (_box((0.035, 0.02, 0.015), (0, 0, 0.015)),)),
        ObjectSpec("g", "gear", "spur gear (Sileane / IPA gear), aluminium, 8 teeth", 2700.0,
                   (_prism(16, gear_r, 0.0, 0.015),
                    *(_box(tooth, ((gear_r + 0.0025) * math.cos(a), (gear_r + 0.0025) * math.sin(a),
                                   0.0075), a)
                      for a in 2 * math.pi * np.arange(8) / 8))),
        ObjectSpec("h", "candlestick",
                   "candlestick (Sileane), ceramic: base, stem and a hollow cup (3 mm wall)", 2000.0,
                   (_prism(16, 0.035, 0.0, 0.012), _prism(12, 0.009, 0.012, 0.100),
                    _prism(16, 0.022, 0.100, 0.104),  # the cup's floor
                    *_ring(12, 0.022 - cup_wall / 2, cup_wall, 0.104, 0.122))),
        ObjectSpec("i", "pepper_mill", "pepper mill (Sileane), wood: body, neck and knob", 800.0,
                   (_prism(16, 0.026, 0.0, 0.100), _prism(12, 0.017, 0.100, 0.115),
                    _prism(12, 0.011, 0.115, 0.130))),
        ObjectSpec("j", "ring_screw", "ring screw / eye bolt (IPA), steel, lying flat", 7800.0,
                   (*(_box((tube, ring_side / 2 + 0.001, 0.006),
                           (ring_r * math.cos(a), ring_r * math.sin(a), 0.006), a)
                      for a in 2 * math.pi * np.arange(8) / 8),
                    _prism(8, 0.006, ring_r + tube - 0.001, 0.065, axis="x",
                           centre=(0, 0, 0.006 * math.cos(math.pi / 8)), flat_down=True))),
        ObjectSpec("k", "gear_shaft", "gear shaft (IPA), aluminium, lying on its gear", 2700.0,
                   (_prism(12, 0.008, -0.06, 0.06, axis="x", centre=(0, 0, shaft_axis)),
                    _prism(16, 0.022, -0.0125, 0.0125, axis="x", centre=(0, 0, shaft_axis),
                           flat_down=True))),
        ObjectSpec("l", "electrical_part", "T-LESS-like electrical part, plastic: body, boss, tab",
                   1200.0,
                   (_box((0.03, 0.02, 0.0125), (0, 0, 0.0125)),
                    _prism(12, 0.010, 0.025, 0.037, centre=(0.015, 0, 0)),
                    _box((0.0075, 0.02, 0.003), (0.0375, 0, 0.003)))),
    ]
    return {o.letter: o for o in objects}


OBJECTS: dict[str, ObjectSpec] = _catalogue()
LETTER_INDEX = {c: i for i, c in enumerate(OBJECTS)}  # a = 0 ... l = 11 (layout seeds use it)
RESTING_POSES = 64  # drops recorded per object for Setup 2's resting poses
BASIC = tuple("abcdef")  # Table 1 objects (Setups 1-3)
INDUSTRIAL = tuple("ghijkl")  # Table 2 objects (Setup 1)


def parse_letters(text: str) -> tuple[str, ...]:
    """'a,b,c' or 'abc' -> ('a', 'b', 'c'); raises ValueError naming an unknown letter."""
    letters = tuple(ch for ch in text.replace(",", " ").split() for ch in ch)
    for ch in letters:
        if ch not in OBJECTS:
            raise ValueError(f"unknown object {ch!r} (objects are a-l)")
    if not letters:
        raise ValueError("no objects given")
    if len(set(letters)) != len(letters):
        raise ValueError(f"object listed twice in {text!r}")
    return letters


# ---------------------------------------------------------------------------
# MJCF and assets


def _fmt(values) -> str:
    return " ".join(f"{v:.6g}" for v in np.ravel(values))


def object_mjcf(spec: ObjectSpec, prefix: str = "") -> tuple[str, str]:
    """`<asset>` entries and `<geom>` elements of one object (the body is the caller's)."""
    assets, geoms = [], []
    for k, piece in enumerate(spec.pieces):
        name = f"{prefix}{spec.letter}_{k}"
        if piece.kind == "box":
            half = math.cos(piece.yaw / 2), 0.0, 0.0, math.sin(piece.yaw / 2)
            geoms.append(f'<geom name="{name}" type="box" size="{_fmt(piece.half_size)}" '
                         f'pos="{_fmt(piece.pos)}" quat="{_fmt(half)}" density="{spec.density:g}"/>')
        else:
            assets.append(f'<mesh name="{name}" vertex="{_fmt(piece.vertices)}"/>')
            geoms.append(f'<geom name="{name}" type="mesh" mesh="{name}" '
                         f'density="{spec.density:g}"/>')
    return "\n".join(assets), "\n".join(geoms)


def standalone_mjcf(spec: ObjectSpec) -> str:
    """A viewable model of one object resting on a plane."""
    assets, geoms = object_mjcf(spec)
    return f"""<mujoco model="{spec.letter}_{spec.name}">
  <!-- {spec.stands_for}; generated by graspjax.sim.objects -->
  <asset>
    <material name="grey" rgba="0.7 0.7 0.7 1"/>
{assets}
  </asset>
  <worldbody>
    <light pos="0 0 1"/>
    <geom name="floor" type="plane" size="0.3 0.3 0.01" material="grey"/>
    <body name="{spec.letter}" pos="0 0 0.001">
      <freejoint/>
{geoms}
    </body>
  </worldbody>
</mujoco>
"""


def _hull_faces(points: np.ndarray):
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    faces = []
    for simplex, eq in zip(hull.simplices, hull.equations, strict=True):
        a, b, c = points[simplex]
        if np.dot(np.cross(b - a, c - a), eq[:3]) < 0:  # outward winding
            simplex = simplex[[0, 2, 1]]
        faces.append(simplex)
    return faces


def object_obj(spec: ObjectSpec) -> str:
    """Wavefront OBJ text of all pieces (one group per piece), triangulated hulls."""
    out, base = io.StringIO(), 1
    out.write(f"# {spec.letter} {spec.name}: {spec.stands_for}\n")
    for k, piece in enumerate(spec.pieces):
        pts = piece.points()
        out.write(f"g piece_{k}\n")
        for p in pts:
            out.write(f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n")
        for face in _hull_faces(pts):
            out.write("f " + " ".join(str(base + int(i)) for i in face) + "\n")
        base += len(pts)
    return out.getvalue()


def resting_poses(letter: str, count: int = RESTING_POSES, seed: int = 0) -> np.ndarray:
    """Rotations (count, 3, 3) in which object `letter` comes to rest after drops on a table.

    Each drop starts from a uniformly random orientation with the lowest
    point 5 mm above the table and runs 2 s of CPU MuJoCo (the object alone,
    friction 0.5); its resting orientation is kept. So every stable face
    appears about as often as a real drop lands on it. Deterministic, so
    kept beside the compilation cache once run (`_resting_poses`).
    """
    return _resting_poses(letter, count, seed).copy()


def resting_poses_of(letters: tuple[str, ...], count: int = RESTING_POSES, seed: int = 0) -> np.ndarray:
    """`resting_poses` of each object in `letters` (len(letters), count, 3, 3), the objects'
    drops in parallel threads (MuJoCo releases the GIL while it steps): building a scene, and
    so its first chunk, waits for them unless the store holds them."""
    with concurrent.futures.ThreadPoolExecutor(len(letters)) as pool:
        return np.stack(list(pool.map(lambda c: resting_poses(c, count, seed), letters)))


@functools.cache
def _resting_poses(letter: str, count: int, seed: int) -> np.ndarray:
    """`_drops`, read from the store beside the compilation cache when an earlier process kept
    them (the drops of the twelve objects take seconds of CPU in every process otherwise), else
    run and kept there."""
    path = _stored_drops(letter, count, seed)
    if path is not None:
        try:
            poses = np.load(path, allow_pickle=False)
            if poses.shape == (count, 3, 3) and poses.dtype == np.float64:
                return poses
        except Exception:  # missing, unreadable or not an array: run the drops (and write them)
            pass
    poses = _drops(letter, count, seed)
    if path is not None:
        buffer = io.BytesIO()
        np.save(buffer, poses, allow_pickle=False)
        keep(path, buffer.getvalue())
    return poses


def _stored_drops(letter: str, count: int, seed: int) -> Path | None:
    """The drops' file in `<compilation cache folder>/resting/` (None when the cache is off),
    keyed by all they depend on: the object's model, this module's source (the drops'
    procedure), count, seed, the versions of MuJoCo and NumPy and the machine's architecture
    (MuJoCo's floats may differ between them; a cache folder may be shared)."""
    import mujoco

    folder = store("resting")
    if folder is None:
        return None
    key = repr((standalone_mjcf(OBJECTS[letter]), Path(__file__).read_bytes(), count, seed,
                mujoco.__version__, np.__version__, platform.machine()))
    return folder / f"{letter}_{hashlib.sha256(key.encode()).hexdigest()[:32]}.npy"


def _drops(letter: str, count: int, seed: int) -> np.ndarray:
    """The drops of `resting_poses`, run with CPU MuJoCo (count, 3, 3)."""
    import mujoco

    spec = OBJECTS[letter]
    model = mujoco.MjModel.from_xml_string(standalone_mjcf(spec))
    model.geom_friction[:, 0] = 0.5
    data = mujoco.MjData(model)
    points = spec.points()
    rng = np.random.default_rng([seed, ord(letter)])
    out = np.empty((count, 3, 3))
    for i in range(count):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        rotation = np.empty(9)
        mujoco.mju_quat2Mat(rotation, q)
        mujoco.mj_resetData(model, data)
        data.qpos[:3] = (0.0, 0.0, 0.005 - (points @ rotation.reshape(3, 3).T)[:, 2].min())
        data.qpos[3:7] = q
        mujoco.mj_step(model, data, nstep=int(2.0 / model.opt.timestep))
        mujoco.mju_quat2Mat(rotation, data.qpos[3:7] / np.linalg.norm(data.qpos[3:7]))
        out[i] = rotation.reshape(3, 3)
    return out


def object_mass(spec: ObjectSpec) -> float:
    """Mass (kg) as MuJoCo computes it from the pieces' volumes and density."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(standalone_mjcf(spec))
    return float(model.body_mass[1])


def catalogue_rows() -> list[dict]:
    rows = []
    for spec in OBJECTS.values():
        size = spec.size
        rows.append({
            "letter": spec.letter, "name": spec.name, "stands_for": spec.stands_for,
            "size_x_m": round(float(size[0]), 4), "size_y_m": round(float(size[1]), 4),
            "size_z_m": round(float(size[2]), 4), "mass_kg": round(object_mass(spec), 4),
            "density_kg_m3": spec.density, "pieces": len(spec.pieces),
            "hull_pieces": sum(p.kind == "hull" for p in spec.pieces),
            "max_hull_vertices": max((len(p.vertices) for p in spec.pieces if p.kind == "hull"),
                                     default=0),
        })
    return rows


def write_assets(folder: str | Path) -> list[Path]:
    """Write every object's MJCF and OBJ and the catalogue into `folder`."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for spec in OBJECTS.values():
        stem = folder / f"{spec.letter}_{spec.name}"
        stem.with_suffix(".xml").write_text(standalone_mjcf(spec))
        stem.with_suffix(".obj").write_text(object_obj(spec))
        written += [stem.with_suffix(".xml"), stem.with_suffix(".obj")]
    rows = catalogue_rows()
    with open(folder / "catalogue.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return [*written, folder / "catalogue.csv"]
