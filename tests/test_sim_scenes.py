"""SceneSpec data, the level generator, its determinism and the JSON reader's checks."""
import json
import math
import re

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.sim.certify import regenerate
from compass_manip.sim.levels import N_OBJECTS, generate_scene
from compass_manip.sim.objects import build_object
from compass_manip.sim.scenes import CabinetSpec, Primitive, SceneObject, SceneSpec
from compass_manip.task import SHAPE_CLASSES

SMALL_SET = [(k, lv, i, 0) for k in range(3) for lv in (1, 2, 3, 4) for i in range(2)]


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


def test_every_scene_has_both_kinds_of_distractor_a_decoy_and_a_shelf_or_frame():
    for sub in SMALL_SET:
        s = regenerate(sub)
        t = s.target
        colour = [o for o in s.clutter if o.role == "colour_distractor"]
        shape = [o for o in s.clutter if o.role == "shape_distractor"]
        assert colour and shape, sub
        for o in colour:  # same colour, another shape and another size
            assert o.colour == t.colour and o.category != t.category
            assert max(abs(np.array(o.size) - np.array(t.size))) > 0.03
        for o in shape:
            assert o.category == t.category and o.colour != t.colour
        assert any(o.role == "decoy" for o in s.clutter)
        assert s.cabinet.shelves or any(f > 0 for f in s.cabinet.frame)
        assert N_OBJECTS[0] <= len(s.objects) <= N_OBJECTS[1]
        assert all(o.category in SHAPE_CLASSES for o in s.objects)
        assert (sub[1] >= 3) == bool(s.base_obstacles)


def test_objects_stay_inside_the_cabinet_and_rest_on_a_surface():
    for sub in SMALL_SET:
        s = regenerate(sub)
        lo, hi = np.array(s.cabinet.interior_min), np.array(s.cabinet.interior_max)
        supports = [z for z, _ in s.cabinet.rows()]
        tops = {o.name: o.aabb()[1][2] for o in s.objects}
        for o in s.objects:
            a, b = o.aabb()
            assert np.all(a >= lo - 1e-6) and np.all(b <= hi + 1e-6), (sub, o.name)
            on_shelf = min(abs(a[2] - z) for z in supports) < 1e-6
            stacked = any(abs(a[2] - top) < 1e-6 for name, top in tops.items() if name != o.name)
            assert on_shelf or stacked, (sub, o.name)


def test_composite_objects_are_one_body_of_several_parts():
    bottle = build_object("b", "bottle", "green", (0.03, 0.12, 0.012, 0.04), 0.3, 0.6, 0.0, 0.3, 0.0)
    mug = build_object("m", "mug", "white", (0.04, 0.09), 0.25, 0.6, 0.2, 0.3, 0.5)
    assert [p.name for p in bottle.parts] == ["b/body", "b/neck"]
    assert bottle.aabb()[1][2] == pytest.approx(0.3 + 0.12 + 0.04)
    assert len(mug.parts) == 10 and mug.size[2] == pytest.approx(0.09)
    scene = regenerate((0, 1, 0, 0))
    assert scene.all_primitives()[-len(scene.target.parts):] == list(scene.target.parts)


def test_task_tells_the_opening_but_not_the_contents():
    s = regenerate((2, 2, 0, 0))
    task = s.task()
    o_lo, o_hi = s.cabinet.opening()
    left, right, top, bottom = s.cabinet.frame
    assert task.space.opening_min == o_lo and task.space.opening_max == o_hi
    assert o_hi[1] == pytest.approx(s.cabinet.interior_max[1] - left)
    assert o_lo[2] == pytest.approx(s.cabinet.interior_min[2] + bottom)
    assert task.target.shape == s.target.category and task.target.colour == s.target.colour
    text = repr(task)
    assert "shelf" not in text and "clutter" not in text and all(str(round(v, 4)) not in text for v in s.target.pos[1:])


def _scene_dict():
    return json.loads(regenerate((0, 1, 0, 0)).to_json())


@pytest.mark.parametrize("edit,field", [
    (lambda d: d["target"]["parts"][0].__setitem__("size", [float("nan"), 0.05]), "target.parts[0].size"),
    (lambda d: d["clutter"][0]["parts"][0].__setitem__("pos", [0.6, float("nan"), 0.3]), "clutter[0].parts[0].pos"),
    (lambda d: d.__setitem__("level", 7), "level"),
    (lambda d: d.__setitem__("level", 1.9), "level"),
    (lambda d: d.__setitem__("seed", "12"), "seed"),
    (lambda d: d.__setitem__("target", [1, 2, 3]), "target"),
    (lambda d: d["cabinet"].__setitem__("interior_min", [0.4, -0.3]), "cabinet.interior_min"),
    (lambda d: d["target"].__setitem__("colour", "mauve"), "target"),
])
def test_bad_scene_json_names_the_field(edit, field):
    d = _scene_dict()
    edit(d)
    text = json.dumps(d)
    with pytest.raises(CompassInputError, match="scene field " + re.escape("'" + field)):
        SceneSpec.from_json(text)


def test_bad_input_is_rejected_with_clear_messages():
    with pytest.raises(CompassInputError, match="level 5 is not allowed"):
        generate_scene(5, 0, np.random.default_rng(0))
    with pytest.raises(CompassInputError, match="numpy.random.Generator"):
        generate_scene(1, 0, 42)
    with pytest.raises(CompassInputError, match="not one of"):
        Primitive("x", "cone", (1.0,), (0.0, 0.0, 0.0))
    with pytest.raises(CompassInputError, match="positive size"):
        Primitive("x", "box", (0.1, -0.1, 0.1), (0.0, 0.0, 0.0))
    with pytest.raises(CompassInputError, match="finite"):
        Primitive("x", "sphere", (math.inf,), (0.0, 0.0, 0.0))
    with pytest.raises(CompassInputError, match="category"):
        SceneObject("o", "teapot", "red", (Primitive("o/b", "sphere", (0.03,), (0.0, 0.0, 0.0)),), 0.1)
    with pytest.raises(CompassInputError, match="does not parse"):
        SceneSpec.from_json("{not json")
    with pytest.raises(CompassInputError, match="missing"):
        SceneSpec.from_json('{"level": 1}')
    with pytest.raises(CompassInputError, match="JSON object"):
        SceneSpec.from_json("[1, 2]")


def test_cabinet_boards_enclose_the_interior_with_frame_and_shelves():
    inner = (Primitive("cab_partition0", "box", (0.15, 0.01, 0.1), (0.65, 0.0, 0.5)),)
    cab = CabinetSpec((0.5, -0.3, 0.4), (0.8, 0.3, 0.9), frame=(0.05, 0.04, 0.03, 0.02), shelves=(0.65,), inner=inner)
    names = {b.name for b in cab.boards()}
    assert {"cab_bottom", "cab_top", "cab_back", "cab_left", "cab_right", "cab_stand", "cab_shelf0",
            "cab_partition0", "frame_left", "frame_right", "frame_top", "frame_bottom"} == names
    back = next(b for b in cab.boards() if b.name == "cab_back")
    assert back.aabb()[0][0] == pytest.approx(0.8)
    frame = next(b for b in cab.boards() if b.name == "frame_left")
    assert frame.aabb()[1][0] == pytest.approx(0.5) and frame.aabb()[0][1] == pytest.approx(0.25)
    assert cab.rows() == [(0.4, pytest.approx(0.63)), (0.65, 0.9)]
    with pytest.raises(CompassInputError, match="shelf"):
        CabinetSpec((0.5, -0.3, 0.4), (0.8, 0.3, 0.9), shelves=(1.2,))
