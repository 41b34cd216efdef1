import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")

#: The repository root and the data shipped with it (data/README.md).
REPO_ROOT = Path(__file__).resolve().parents[1]
MBM_ARCHIVE = REPO_ROOT / "data" / "mbm-panda.tar.bz2"

# Property-based suites (tests/test_inputs_*.py): a few examples per property in `make test`,
# many under COMPASS_HYPOTHESIS=slow (or `pytest -m slow`, which selects the slow profile).
try:
    from hypothesis import HealthCheck, settings

    _common = dict(deadline=None, derandomize=True, print_blob=True,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    settings.register_profile("ci", max_examples=12, **_common)
    settings.register_profile("slow", max_examples=300, **_common)
    settings.load_profile(os.environ.get("COMPASS_HYPOTHESIS", "ci"))
except ImportError:  # pragma: no cover - hypothesis is in the [test] extra
    pass


def _slow_run(config) -> bool:
    return (config.getoption("markexpr", default="") or "").strip() == "slow"


def pytest_configure(config):
    """`pytest -m slow`: the property suites run too, with the slow profile's examples."""
    if _slow_run(config) and "COMPASS_HYPOTHESIS" not in os.environ:
        try:
            from hypothesis import settings

            settings.load_profile("slow")
        except ImportError:  # pragma: no cover
            pass


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    if _slow_run(config):  # select the property suites under -m slow as well
        for item in items:
            if item.path.name.startswith("test_inputs_"):
                item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def mbm_archive() -> str:
    """Path of the MotionBenchMaker archive shipped in data/; a missing file fails the test."""
    assert MBM_ARCHIVE.is_file(), f"{MBM_ARCHIVE} is missing: it ships with the repository (data/README.md)"
    return str(MBM_ARCHIVE)


# ----------------------------------------------------------------------------- MuJoCo oracles
def mbm_mujoco_scene(problem):
    """The Panda + hand and a MotionBenchMaker problem's obstacles as MuJoCo geoms:
    (model, data, set of obstacle geom ids). The oracle for collision tests and floors."""
    import mujoco
    import numpy as np

    from compass_manip.geometry import R_to_quat
    from compass_manip.robot.model import build_robot_spec

    spec = build_robot_spec(actuators=False)
    G = mujoco.mjtGeom
    for i, (T, h) in enumerate(problem.boxes):
        spec.worldbody.add_geom(name=f"obs_b{i}", type=G.mjGEOM_BOX, size=list(h), pos=list(T[:3, 3]),
                                quat=list(R_to_quat(T[:3, :3])))
    for i, (T, r, h) in enumerate(problem.cylinders):
        spec.worldbody.add_geom(name=f"obs_c{i}", type=G.mjGEOM_CYLINDER, size=[r, h, 0], pos=list(T[:3, 3]),
                                quat=list(R_to_quat(T[:3, :3])))
    for i, (c, r) in enumerate(problem.spheres):
        spec.worldbody.add_geom(name=f"obs_s{i}", type=G.mjGEOM_SPHERE, size=[r, 0, 0], pos=list(np.asarray(c)))
    m = spec.compile()
    obstacles = {g for g in range(m.ngeom) if m.geom(g).name.startswith("obs_")}
    assert len(obstacles) == len(problem.boxes) + len(problem.cylinders) + len(problem.spheres)
    return m, mujoco.MjData(m), obstacles


def mujoco_penetrating_states(scene, Q, finger_width) -> int:
    """How many configurations Q (n, 7) [rad] put a moving robot geom into an obstacle
    (MuJoCo contacts with negative distance); scene = mbm_mujoco_scene(...)."""
    import mujoco

    m, d, obstacles = scene
    base = m.body("panda_link0").id
    n = 0
    for q in Q:
        d.qpos[:7] = q
        d.qpos[7:9] = 0.5 * finger_width
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        c = d.contact[: d.ncon]
        for a, b, dist in zip(c.geom1, c.geom2, c.dist):
            if dist < 0 and ((a in obstacles) != (b in obstacles)) and m.geom_bodyid[b if a in obstacles else a] != base:
                n += 1
                break
    return n


@pytest.fixture(scope="module")
def level4_world():
    """The simulator of the default set's Level-4 scene 0 (seed 0), shared by a test module."""
    from compass_manip.sim.certify import certified_scene
    from compass_manip.sim.world import World

    w = World(certified_scene(4, 0, 0).scene)
    yield w
    w.close()
