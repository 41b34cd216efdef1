"""MotionBenchMaker loading, solving and the `compass mbm` command."""
import json
import os
import tarfile

import numpy as np
import pytest

from compass_manip.cli import main
from compass_manip.errors import CompassInputError
from compass_manip.bench.mbm import (
    FINE_FIT,
    MbmOutcome,
    MbmProblem,
    Rejection,
    family_stats,
    load_problems,
    path_is_valid,
    solve_problem,
)
from compass_manip.motion.planner import PlannerConfig

from conftest import MBM_ARCHIVE, mbm_mujoco_scene

ARCHIVE = str(MBM_ARCHIVE)  # shipped in data/ (data/README.md); a missing file fails every test here
FAMILIES = ("bookshelf_small", "box", "cage", "table_pick")
N_PER_FAMILY = 2


def test_archive_ships_with_the_repository():
    assert os.path.isfile(ARCHIVE), f"{ARCHIVE} is missing"
    with tarfile.open(ARCHIVE, "r:bz2") as tar:
        names = [m.name for m in tar.getmembers() if m.isfile()]
    assert len(names) == 800  # 4 families x 100 scene + request pairs


#: solved of the 8-problem subset without refinement (measured: 8 of 8 on 2026-11-22)
MIN_SOLVED_OF_SUBSET = 7


def _extract(root, numbers, family_filter=None) -> str:
    """Problems `numbers` of each family (or of the families accepted by family_filter)."""
    wanted = {f"{k}{i:04d}.yaml" for k in ("scene", "request") for i in numbers}
    with tarfile.open(ARCHIVE, "r:bz2") as tar:
        for m in tar.getmembers():
            family = os.path.basename(os.path.dirname(m.name))
            if m.isfile() and os.path.basename(m.name) in wanted and (family_filter is None or family_filter(family)):
                dest = root / family / os.path.basename(m.name)
                dest.parent.mkdir(parents=True, exist_ok=True)
                dest.write_bytes(tar.extractfile(m).read())
    return str(root)


@pytest.fixture(scope="module")
def subset(tmp_path_factory) -> str:
    """The first N_PER_FAMILY problems of each family, extracted to family folders."""
    return _extract(tmp_path_factory.mktemp("mbm"), range(1, N_PER_FAMILY + 1))


@pytest.fixture(scope="module")
def refined(tmp_path_factory):
    """bookshelf_small 0069 and table_pick 0041: goals the default spheres reject (the wrist /
    hand spheres overshoot by a few mm) but that are 6.5 and 3.2 mm clear in MuJoCo."""
    root = tmp_path_factory.mktemp("mbm_refined")
    _extract(root, [69], lambda f: f.startswith("bookshelf"))
    _extract(root, [41], lambda f: f.startswith("table_pick"))
    return load_problems(str(root))


def test_subset_loads_per_family(subset):
    problems = load_problems(subset)
    assert [p.family for p in problems] == [f for f in FAMILIES for _ in range(N_PER_FAMILY)]
    assert [p.name for p in problems[:2]] == ["0001", "0002"]
    for p in problems:
        assert p.q_start.shape == (7,) and p.q_goals.shape[1] == 7 and len(p.boxes) >= 1
        assert p.finger_width == pytest.approx(0.13)  # both finger joints at 0.065 m
        assert len(p.obstacle_ids) == len(p.boxes) + len(p.cylinders) + len(p.spheres)


def test_bookshelf_0001_golden_values(subset):
    p = load_problems(subset)[0]
    np.testing.assert_allclose(p.q_start, [0, -0.785, 0, -2.356, 0, 1.571, 0.785])
    np.testing.assert_allclose(p.q_goals[0, :2], [1.48904932702624, -0.1466710603206631])
    # shelf_bottom: box 1.2 x 1 x 0.04 m, yawed by 2 * atan2(-0.5234, 0.8521) about z
    i = p.obstacle_ids.index("shelf_bottom")
    T, half = p.boxes[i]
    np.testing.assert_allclose(half, [0.6, 0.5, 0.02])
    np.testing.assert_allclose(T[:3, 3], [0.5896088862799895, -1.012333107355894, 0.2179866994332423])
    yaw = 2 * np.arctan2(-0.5233762232815127, 0.8521017127688338)
    np.testing.assert_allclose(T[:3, :3], [[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]], atol=1e-9)
    # Can1: cylinder dimensions [height 0.14, radius 0.03]
    j = p.obstacle_ids.index("Can1") - len(p.boxes)
    _, r, hl = p.cylinders[j]
    assert (r, hl) == pytest.approx((0.03, 0.07))


def test_archive_and_folder_give_the_same_problems(subset, tmp_path):
    path = tmp_path / "small.tar.bz2"
    with tarfile.open(path, "w:bz2") as tar:
        tar.add(subset, arcname="problems")
    a, b = load_problems(subset), load_problems(str(path))
    assert [(p.family, p.name) for p in a] == [(p.family, p.name) for p in b]
    for p, q in zip(a, b):
        np.testing.assert_array_equal(p.q_goals, q.q_goals)
        np.testing.assert_array_equal(p.boxes[0][0], q.boxes[0][0])


def test_object_pose_mapping_positions_and_sphere(tmp_path):
    (tmp_path / "scene0007.yaml").write_text(
        "world:\n  collision_objects:\n"
        "    - id: ball\n      pose: {position: {x: 1, y: 0, z: 0}, orientation: {x: 0, y: 0, z: 1, w: 0}}\n"
        "      primitives: [{type: sphere, dimensions: [0.1]}]\n"
        "      primitive_poses: [{position: [0.5, 0, 0.2], orientation: [0, 0, 0, 1]}]\n"
    )
    joints = [f"panda_joint{i}" for i in range(1, 8)]
    (tmp_path / "request0007.yaml").write_text(
        f"start_state: {{joint_state: {{name: {joints}, position: [0, 0, 0, -1, 0, 1, 0]}}}}\n"
        "goal_constraints:\n  - joint_constraints:\n"
        + "".join(f"      - {{joint_name: {j}, position: 0.5}}\n" for j in joints[::-1])
    )
    (p,) = load_problems(str(tmp_path))
    assert p.family == tmp_path.name and p.name == "0007" and p.obstacle_ids == ("ball",)
    c, r = p.spheres[0]
    np.testing.assert_allclose(c, [0.5, 0.0, 0.2])  # (1,0,0) + Rz(pi) (0.5,0,0.2)
    assert r == 0.1
    np.testing.assert_allclose(p.q_goals, np.full((1, 7), 0.5))
    assert p.finger_width == 0.08  # no finger joint in the start state: the real maximum opening
    request = (tmp_path / "request0007.yaml").read_text()
    (tmp_path / "request0007.yaml").write_text(request.replace(
        "position: [0, 0, 0, -1, 0, 1, 0]}", "position: [0, 0, 0, -1, 0, 1, 0, 0.01, 0.02]}").replace(
        f"name: {joints}", f"name: {joints + ['panda_finger_joint1', 'panda_finger_joint2']}"))
    assert load_problems(str(tmp_path))[0].finger_width == pytest.approx(0.03)
    (tmp_path / "request0007.yaml").write_text(request.replace(
        "position: [0, 0, 0, -1, 0, 1, 0]}", "position: [0, 0, 0, -1, 0, 1, 0, 0.15, 0.15]}").replace(
        f"name: {joints}", f"name: {joints + ['panda_finger_joint1', 'panda_finger_joint2']}"))
    with pytest.raises(CompassInputError, match="finger opening 0.3 m"):
        load_problems(str(tmp_path))


def test_missing_request_and_bad_paths(tmp_path):
    (tmp_path / "scene0001.yaml").write_text("world: {collision_objects: []}\n")
    with pytest.raises(CompassInputError, match="request0001"):
        load_problems(str(tmp_path))
    with pytest.raises(CompassInputError, match="no such file"):
        load_problems(str(tmp_path / "missing"))
    bad = tmp_path / "broken.tar.bz2"
    bad.write_bytes(b"not an archive")
    with pytest.raises(CompassInputError, match="archive"):
        load_problems(str(bad))


def test_solve_subset_paths_valid(subset):
    from compass_manip.robot.spheres import panda_sphere_model

    problems = load_problems(subset)
    sm = panda_sphere_model(finger_width=problems[0].finger_width)
    outcomes = [solve_problem(p, sm, PlannerConfig(time_budget=5.0), np.random.default_rng(i))
                for i, p in enumerate(problems)]
    for o in outcomes:
        assert not o.path_invalid
        assert o.solved == (o.rejection is None)  # every accepted problem is solved
        assert (o.rejection is None) == np.isfinite(o.plan_ms)
    stats = family_stats(outcomes)
    assert [s.family for s in stats] == list(FAMILIES)
    for s in stats:
        assert s.problems == N_PER_FAMILY and s.solved + s.rejected == N_PER_FAMILY
    assert sum(o.solved for o in outcomes) >= MIN_SOLVED_OF_SUBSET


def test_out_of_limit_goal_is_rejected_not_raised(subset):
    p = load_problems(subset)[0]
    bad = MbmProblem(p.family, p.name, p.boxes, p.cylinders, p.spheres, p.q_start,
                     np.r_[p.q_goals[0, :3], 0.3, p.q_goals[0, 4:]][None], p.obstacle_ids)
    o = solve_problem(bad, None, PlannerConfig(), np.random.default_rng(0))
    assert o.rejection is Rejection.GOAL_OUTSIDE_LIMITS and not o.solved
    # counted as outside_limits, not as rejected (in collision)
    ok = MbmOutcome(p.family, "x", None, True, False, 2.0, 3)
    hit = MbmOutcome(p.family, "y", Rejection.GOAL_IN_COLLISION, False, False, float("nan"), 0)
    (s,) = family_stats([o, ok, hit, ok])
    assert (s.problems, s.rejected, s.outside_limits, s.solved, s.plan_ms_median) == (4, 1, 1, 2, 2.0)
    assert s.as_json()["outside_limits"] == 1 and s.as_json()["rejected"] == 1


def test_path_is_valid_detects_a_collision(subset):
    """bookshelf 0001: the straight line from the start to the first goal goes through the
    shelf (MuJoCo finds up to 4 cm of penetration on it); both ends are free."""
    from compass_manip.bench.mbm import problem_validity
    from compass_manip.motion.timing import densify
    from compass_manip.robot.spheres import panda_sphere_model

    p = load_problems(subset)[0]
    assert (p.family, p.name) == ("bookshelf_small", "0001")
    v = problem_validity(p, panda_sphere_model(finger_width=p.finger_width))
    m, d, obstacles = mbm_mujoco_scene(p)
    line = np.stack([p.q_start, p.q_goals[0]])
    true = np.array([_true_clearance(m, d, obstacles, q, p.finger_width) for q in densify(line, 0.01)])
    assert true[0] > 0 and true[-1] > 0 and true.min() < -0.02  # the oracle: ends free, the line blocked
    assert v.is_valid(line[0]) and v.is_valid(line[1])
    assert not path_is_valid(line, v, 0.005)
    assert not path_is_valid(np.stack([p.q_start, p.q_start, p.q_goals[0], p.q_goals[0]]), v, 0.005)
    assert path_is_valid(np.stack([p.q_start, p.q_start]), v, 0.005)


def test_cli_json_shape(subset, capsys):
    # a wall-time budget far above the ~0.1 s these problems take, so a loaded machine cannot fail one
    assert main(["mbm", subset, "--json", "--no-progress", "--time-budget", "20"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == len(FAMILIES)
    for line, fam in zip(lines, FAMILIES):
        d = json.loads(line)
        assert set(d) == {"family", "problems", "rejected", "outside_limits", "solved", "plan_ms_median",
                          "plan_ms_p90"}
        assert d["family"] == fam and d["problems"] == N_PER_FAMILY
        assert d["solved"] + d["rejected"] + d["outside_limits"] == N_PER_FAMILY


def test_cli_table(subset, capsys):
    assert main(["mbm", subset, "--no-progress"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:5] == ["family", "problems", "rejected", "solved", "outside_limits"]
    assert [l.split()[0] for l in out[1:5]] == list(FAMILIES)
    assert any(l.startswith("finger opening from each problem's start state: 0.130 m") for l in out)


@pytest.mark.parametrize("name", ["missing_dir", "bad.tar.bz2"])
def test_cli_bad_path_exit_2_one_line(tmp_path, capsys, name):
    path = tmp_path / name
    if name.endswith(".bz2"):
        path.write_bytes(b"garbage")
    assert main(["mbm", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("compass mbm: error: ") and str(path) in err


def test_explain_names_the_link_and_the_obstacle(subset):
    from compass_manip.geometry import make_T
    from compass_manip.bench.mbm import explain_invalid
    from compass_manip.robot.kinematics import PandaKinematics
    from compass_manip.robot.spheres import panda_sphere_model

    p = load_problems(subset)[0]
    c = PandaKinematics().T_world_hand(p.q_start)[:3, 3]
    boxed = MbmProblem(p.family, p.name, ((make_T(t=c), np.full(3, 0.03)),), (), (), p.q_start,
                       p.q_goals, ("wrist_box",))
    sm = panda_sphere_model()
    why = explain_invalid(boxed, sm, p.q_start)
    assert why and all("'wrist_box'" in w for w in why if not w.startswith("self:"))
    assert any(w.startswith("hand/panda_hand touches 'wrist_box'") for w in why)
    o = solve_problem(boxed, sm, PlannerConfig(), np.random.default_rng(0))
    assert o.rejection is Rejection.START_IN_COLLISION


def _true_clearance(m, d, obstacles, q, width):
    """Smallest MuJoCo signed distance [m] between moving robot geoms and the obstacles."""
    import mujoco

    d.qpos[:7] = q
    d.qpos[7:9] = 0.5 * width
    mujoco.mj_kinematics(m, d)
    base = m.body("panda_link0").id
    robot = [g for g in range(m.ngeom) if g not in obstacles and m.geom_bodyid[g] != base
             and (m.geom_contype[g] or m.geom_conaffinity[g])]
    ft = np.zeros(6)
    return min(mujoco.mj_geomDistance(m, d, a, b, 0.05, ft) for a in robot for b in obstacles)


def test_fine_model_accepts_refined_goals_and_stays_conservative(refined):
    """The fine spheres accept goals the default ones reject; near those goals (where the fine
    model matters) every configuration it calls free is free in MuJoCo at the same opening."""
    from compass_manip.bench.mbm import problem_validity
    from compass_manip.robot.spheres import panda_sphere_model

    rng = np.random.default_rng(3)
    n_free = n_hit = 0
    for p in refined:
        coarse = panda_sphere_model(finger_width=p.finger_width)
        fine = panda_sphere_model(finger_width=p.finger_width, fit=FINE_FIT)
        assert fine.n_spheres > coarse.n_spheres
        v_coarse, v_fine = problem_validity(p, coarse), problem_validity(p, fine)
        assert not v_coarse.is_valid(p.q_goals[0]) and v_fine.is_valid(p.q_goals[0])
        assert v_fine.clearance(p.q_goals[0]) > v_coarse.clearance(p.q_goals[0]) + 0.002
        m, d, obstacles = mbm_mujoco_scene(p)
        assert _true_clearance(m, d, obstacles, p.q_goals[0], p.finger_width) > 0.003
        Q = np.clip(p.q_goals[0] + rng.normal(0.0, 0.03, (150, 7)), *_limits())
        free = v_fine.are_valid(Q)
        true = np.array([_true_clearance(m, d, obstacles, q, p.finger_width) for q in Q])
        assert not np.any(free & (true < 0)), "fine spheres free where MuJoCo penetrates"
        n_free += int(free.sum())
        n_hit += int((true < 0).sum())
    assert n_free > 30 and n_hit > 30  # both verdicts occur near these goals


def _limits():
    from compass_manip.robot.model import Q_MAX, Q_MIN

    return Q_MIN, Q_MAX


def test_refinement_solves_with_the_fine_model(refined):
    from compass_manip.bench.mbm import explain_invalid, problem_validity
    from compass_manip.robot.spheres import panda_sphere_model

    p = refined[0]
    coarse = panda_sphere_model(finger_width=p.finger_width)
    fine = panda_sphere_model(finger_width=p.finger_width, fit=FINE_FIT)
    cfg = PlannerConfig(time_budget=5.0)
    o = solve_problem(p, coarse, cfg, np.random.default_rng(0))
    assert o.rejection is Rejection.GOAL_IN_COLLISION and not o.refined
    o = solve_problem(p, coarse, cfg, np.random.default_rng(0), fine_model=lambda: fine)
    assert o.rejection is None and o.refined and o.solved and not o.path_invalid
    assert family_stats([o])[0].refined == 1
    why = explain_invalid(p, coarse, p.q_goals[0], fine)
    assert why and all("fine spheres +" in w for w in why if not w.startswith("self:"))
    # table_pick 0041: the hand's spheres reject the goal, the fine ones accept and plan it
    o = solve_problem(refined[1], coarse, cfg, np.random.default_rng(0), fine_model=lambda: fine)
    assert o.refined and o.solved
    assert problem_validity(refined[1], fine).is_valid(refined[1].q_start)
