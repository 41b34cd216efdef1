"""Layers together: wrist scan -> map -> distance field -> plan -> time -> execute in the simulator."""
import numpy as np

from compass_manip.exploration.wrist_sweep import wrist_sweep
from compass_manip.mapping.distance import DistanceField
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
from compass_manip.mapping.observe import integrate_observation
from compass_manip.motion.planner import PlanFailure, plan
from compass_manip.motion.primitives import DistanceGrid
from compass_manip.motion.timing import time_parameterize
from compass_manip.motion.validity import ValidityChecker
from compass_manip.robot.model import Q_MAX, Q_MIN
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.oracle import find_grasp
from compass_manip.sim.executor import ExecutorConfig, execute
from compass_manip.sim.world import World
from compass_manip.types import Trajectory


def test_plan_on_the_scanned_map_and_execute_without_contact():
    scene = certified_scene(3, 2, 0).scene
    world = World(scene)
    spheres = panda_sphere_model(world.robot)
    q_home = np.asarray(world.robot.q_home)
    way = wrist_sweep(q_home)
    scan = execute(world, Trajectory(np.arange(len(way), dtype=float), way), ExecutorConfig(frame_rate=3.0))
    assert scan.completed and not scan.contacts
    occ = OccupancyMap(MapConfig())
    for f in [world.render(q_home), *scan.frames]:
        integrate_observation(occ, f, spheres, world.camera.depth_max)
    # the robot's own volume along the scan is safe; everything unseen is not
    carve = spheres.sphere_centers(way)
    field = DistanceField.from_map(occ, safe_spheres=(carve.reshape(-1, 3), np.tile(spheres.radii + 0.03, len(way))))
    checker = ValidityChecker(spheres, grid=DistanceGrid.from_distance_field(field))
    assert checker.is_valid(q_home)

    rng = np.random.default_rng(0)
    # only space the scan has seen or the arm has occupied is free: goals move the wrist
    step = np.zeros((400, 7))
    step[:, 4:] = rng.uniform(-0.5, 0.5, (400, 3))
    goals = [q for q in np.clip(q_home + step, Q_MIN, Q_MAX) if checker.is_valid(q)]
    goals = [q for q in goals if np.max(np.abs(q - q_home)) > 0.3][:3]
    assert goals, "no valid goal found in the scanned free space"
    for q_goal in goals:
        res = plan(q_home, q_goal[None], checker, rng=rng)
        assert res.success, res.failure
        assert checker.path_valid(res.path)
        traj = time_parameterize(res.path)
        run = execute(world, traj, ExecutorConfig(frame_rate=0.0, check_step=0.002))
        assert run.completed and not run.contacts  # zero ground-truth contacts
        world.set_q(q_home)

    # the target's grasp lies in space the scan has not seen: the planner refuses it
    grasp = find_grasp(world)
    res = plan(q_home, grasp.q_grasp[None], checker, rng=rng)
    assert not res.success and res.failure is PlanFailure.GOAL_INVALID
    world.close()
