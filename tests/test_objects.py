import csv
from pathlib import Path

import numpy as np
import pytest

from graspjax.config import DetectorConfig, GripperConfig
from graspjax.sim import objects
from graspjax.sim.objects import (
    BASIC,
    INDUSTRIAL,
    OBJECTS,
    _resting_poses,
    catalogue_rows,
    object_mass,
    parse_letters,
    resting_poses_of,
    write_assets,
)


def test_twelve_objects_with_small_convex_pieces():
    assert "".join(OBJECTS) == "abcdefghijkl" and BASIC + INDUSTRIAL == tuple(OBJECTS)
    for spec in OBJECTS.values():
        assert spec.pieces and spec.density > 0
        for piece in spec.pieces:
            assert piece.kind in ("box", "hull")
            if piece.kind == "hull":
                assert 4 <= len(piece.vertices) <= 32
        pts = spec.points()
        assert pts[:, 2].min() == pytest.approx(0.0, abs=1e-9)  # resting on z = 0
    # The industrial parts are concave: several convex pieces each.
    assert all(len(OBJECTS[c].pieces) >= 2 for c in INDUSTRIAL)


def test_every_object_fits_the_default_gripper_in_some_direction():
    """Some horizontal width of each object fits the opening minus the clearances."""
    limit = GripperConfig().opening - 2 * DetectorConfig().clearance
    for spec in OBJECTS.values():
        xy = spec.points()[:, :2]
        widths = [np.ptp(xy @ [np.cos(a), np.sin(a)]) for a in np.linspace(0, np.pi, 180)]
        assert min(widths) <= limit, spec.letter


def test_masses_follow_volume_and_density():
    # A 5 cm cube of 700 kg/m^3 weighs 87.5 g; MuJoCo computes it from the geometry.
    assert object_mass(OBJECTS["a"]) == pytest.approx(0.125e-3 * 700)
    cylinder = OBJECTS["e"]  # 16-gon prism, circumradius 2.5 cm, 7 cm tall
    area = 0.5 * 16 * 0.025**2 * np.sin(2 * np.pi / 16)
    assert object_mass(cylinder) == pytest.approx(area * 0.07 * 700, rel=1e-4)


def test_committed_assets_match_the_generator(tmp_path):
    write_assets(tmp_path)
    committed = Path(__file__).resolve().parents[1] / "assets" / "objects"
    for path in sorted(tmp_path.iterdir()):
        with open(f"{committed}/{path.name}") as handle:
            assert handle.read() == path.read_text(), f"{path.name} is stale: regenerate assets"
    with open(f"{committed}/catalogue.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["letter"] for r in rows] == list("abcdefghijkl")
    assert {r["name"] for r in rows} == {r["name"] for r in catalogue_rows()}


def test_parse_letters():
    assert parse_letters("a,b,c") == ("a", "b", "c")
    assert parse_letters("ghi") == ("g", "h", "i")
    with pytest.raises(ValueError, match="unknown object 'z'"):
        parse_letters("a,z")
    with pytest.raises(ValueError, match="twice"):
        parse_letters("a,a")


def test_resting_poses_of_a_scene_are_each_object_s_own_drops(monkeypatch):
    """The drops of a scene's objects run in threads: each object's poses are those of its own
    drops run alone (deterministic per object), in the scene's order, and are rotations."""
    monkeypatch.setattr(objects, "store", lambda name: None)  # no store: the threads drop
    _resting_poses.cache_clear()
    together = resting_poses_of(("g", "a"), count=4, seed=3)
    alone = np.stack([objects._drops(c, 4, 3) for c in "ga"])
    assert together.shape == (2, 4, 3, 3)
    np.testing.assert_array_equal(together, alone)
    identity = np.broadcast_to(np.eye(3), together.shape)
    np.testing.assert_allclose(together @ np.swapaxes(together, -1, -2), identity, atol=1e-9)


def test_drops_are_kept_in_the_store_and_read_back(tmp_path, monkeypatch):
    """The drops run once: a later process reads the very same poses from the store beside the
    compilation cache; an unreadable file is run again and rewritten; other drops (count,
    seed, object) get files of their own; with the cache off nothing is kept."""
    monkeypatch.setattr(objects, "store", lambda name: tmp_path / name)
    _resting_poses.cache_clear()
    ran = objects._drops("a", 3, 7)
    first = _resting_poses("a", 3, 7)
    np.testing.assert_array_equal(first, ran)
    (path,) = (tmp_path / "resting").iterdir()

    def no_drops(*args):
        raise AssertionError("the drops ran again")

    _resting_poses.cache_clear()
    with monkeypatch.context() as m:  # a new process: the function's cache is empty
        m.setattr(objects, "_drops", no_drops)
        np.testing.assert_array_equal(_resting_poses("a", 3, 7), ran)

    for broken in (b"not an array", b""):  # unreadable or empty (a crash before the rename)
        path.write_bytes(broken)
        _resting_poses.cache_clear()
        np.testing.assert_array_equal(_resting_poses("a", 3, 7), ran)
        np.testing.assert_array_equal(np.load(path), ran)

    _resting_poses("a", 2, 7), _resting_poses("a", 3, 8), _resting_poses("b", 3, 7)
    assert len(list((tmp_path / "resting").iterdir())) == 4

    monkeypatch.setattr(objects, "store", lambda name: None)
    assert objects._stored_drops("a", 3, 7) is None
    _resting_poses.cache_clear()
    np.testing.assert_array_equal(_resting_poses("a", 3, 7), ran)
    assert len(list((tmp_path / "resting").iterdir())) == 4
    _resting_poses.cache_clear()
