"""`World.contacts` filters MuJoCo's contact list as arrays: the same contacts as reading
every contact one by one, on random configurations that hit the scene, the arm itself, or
nothing."""
import mujoco
import numpy as np
import pytest

from compass_manip.robot.model import Q_HOME
from compass_manip.sim.world import Contact, World


def _one_by_one(world: World, include_self: bool) -> list[Contact]:
    m, d = world.model, world.data
    mujoco.mj_collision(m, d)
    out = []
    for i in range(d.ncon):
        c = d.contact[i]
        g1, g2 = int(c.geom1), int(c.geom2)
        r1, r2 = world.is_robot_geom[g1], world.is_robot_geom[g2]
        if c.dist >= 0 or not (r1 or r2):
            continue
        if r1 and r2 and (not include_self or world._self_pair_ignored(m.geom_bodyid[g1], m.geom_bodyid[g2])):
            continue
        rg, og = (g1, g2) if r1 else (g2, g1)
        if rg == world._base_geom and og == world._floor_geom:
            continue
        out.append(Contact(world._geom_name(rg), world._geom_name(og), float(-c.dist), tuple(map(float, c.pos))))
    return out


@pytest.fixture(scope="module")
def world(level4_world):
    return level4_world


def test_array_filter_equals_one_by_one(world):
    rng = np.random.default_rng(7)
    lo, hi = world.model.jnt_range[:7, 0], world.model.jnt_range[:7, 1]
    kinds = {"scene": 0, "self": 0, "free": 0}
    for _ in range(600):  # the default set's level-4 scene 0 needs 600 for 10 self-only cases
        q = np.clip(Q_HOME + rng.normal(0.0, 0.8, 7), lo, hi)
        for include_self in (True, False):
            got = world.contacts(q, include_self=include_self)
            assert got == _one_by_one(world, include_self)
        robot_names = {c.other_geom for c in world.contacts(q, include_self=True)}
        own = world.contacts(q, include_self=False)
        kinds["free" if not robot_names else "scene" if own else "self"] += 1
    assert min(kinds.values()) >= 10, kinds  # all three cases were exercised
