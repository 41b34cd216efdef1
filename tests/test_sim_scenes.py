"""SceneSpec data, the level generator and its determinism."""
import json

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.sim.certify import regenerate
from compass_manip.sim.levels import generate_scene
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneSpec


@pytest.mark.parametrize("level", [1, 2, 3, 4])
def test_json_round_trip_is_exact(level):
    scene = regenerate((5, level, 3, 0))
    text = scene.to_json()
    back = SceneSpec.from_json(text)
    assert back == scene
    assert back.to_json() == text
    json.loads(text)  # plain JSON


def test_same_seed_same_scene_bit_for_bit():
    a = generate_scene(4, 7, np.random.default_rng([1, 4, 7, 0]))
    b = generate_scene(4, 7, np.random.default_rng([1, 4, 7, 0]))
    c = generate_scene(4, 7, np.random.default_rng([2, 4, 7, 0]))
    assert a.to_json() == b.to_json()
    assert a.to_json() != c.to_json()


def test_levels_have_their_ingredients():
    for k in range(5):
        l1, l2 = regenerate((k, 1, 0, 0)), regenerate((k, 2, 0, 0))
        l3, l4 = regenerate((k, 3, 0, 0)), regenerate((k, 4, 0, 0))
        assert not l1.base_obstacles and not l2.base_obstacles
        assert l3.base_obstacles and l4.base_obstacles
        # L2's board is taller than L1's and the pocket has a side wall
        board = lambda s: next(p for p in s.clutter if p.name == "occluder0")  # noqa: E731
        assert board(l2).size[2] > board(l1).size[2]
        assert any(p.name == "occluder1" for p in l2.clutter)


def test_objects_stay_inside_the_cabinet_and_do_not_overlap():
    for k in range(10):
        s = regenerate((k, 2, 1, 0))
        lo, hi = np.array(s.cabinet.interior_min), np.array(s.cabinet.interior_max)
        for p in list(s.clutter) + [s.target]:
            a, b = p.aabb()
            assert np.all(a >= lo - 1e-9) and np.all(b <= hi + 1e-9), p.name
            assert abs(a[2] - lo[2]) < 1e-9, f"{p.name} does not rest on the cabinet floor"


def test_target_is_graspable_size_and_red():
    for k in range(10):
        t = regenerate((k, 1, 0, 0)).target
        assert 2 * min(t.half_extents[:2]) < 0.07
        assert t.rgba[0] > 0.8 and t.rgba[1] < 0.1 and t.rgba[2] < 0.1


def test_bad_input_is_rejected_with_clear_messages():
    with pytest.raises(CompassInputError, match="level 5 is not allowed"):
        generate_scene(5, 0, np.random.default_rng(0))
    with pytest.raises(CompassInputError, match="numpy.random.Generator"):
        generate_scene(1, 0, 42)
    with pytest.raises(CompassInputError, match="not one of"):
        Primitive("x", "cone", (1.0,), (0.0, 0.0, 0.0))
    with pytest.raises(CompassInputError, match="positive size"):
        Primitive("x", "box", (0.1, -0.1, 0.1), (0.0, 0.0, 0.0))
    with pytest.raises(CompassInputError, match="does not parse"):
        SceneSpec.from_json("{not json")
    with pytest.raises(CompassInputError, match="missing or bad field"):
        SceneSpec.from_json('{"level": 1}')


def test_cabinet_boards_enclose_the_interior():
    cab = CabinetSpec((0.5, -0.3, 0.4), (0.8, 0.3, 0.9), shelves=(0.65,), partitions=((0.0, 0.5),))
    names = [b.name for b in cab.boards()]
    assert {"cab_bottom", "cab_top", "cab_back", "cab_left", "cab_right", "cab_stand", "cab_shelf0",
            "cab_partition0"} == set(names)
    back = next(b for b in cab.boards() if b.name == "cab_back")
    assert back.aabb()[0][0] == pytest.approx(0.8)
