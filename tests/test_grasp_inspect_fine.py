"""The grasp-only harness's INSPECT model gives the hypotheses the selection's fine local map:
the kept frames (and every frame observed later) integrated at 5 mm around the target's
points, equal to integrating them afresh (`sim.grasp_inspect.HarnessModel.fine_map`)."""
from types import SimpleNamespace

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.grasp.field import local_fine_map
from compass_manip.mapping.observe import integrate_observation
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.robot.model import RobotConfig
from compass_manip.robot.spheres import panda_sphere_model
from compass_manip.sim.grasp_inspect import HarnessModel
from compass_manip.task import ConfinedSpace, TargetQuery, Task

Q_AWAY = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785])  # the arm far below the cameras


def _frame(x: float, depth_m: float):
    """A 5x5 depth image looking down -z from (x, 0.5, 0.9) [m] onto a plane depth_m below."""
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = [x, 0.5, 0.9]
    K = np.array([[20.0, 0, 2.0], [0, 20.0, 2.0], [0, 0, 1]])
    return SimpleNamespace(depth=np.full((5, 5), depth_m), K=K, T_world_cam=T, q=Q_AWAY)


def _task():
    space = ConfinedSpace((0.9, 0.2, 0.3), (1.3, 0.8, 1.0), (0.9, 0.2, 0.3), (0.9, 0.8, 1.0))
    return Task(robot_base_pos=(0.0, 0.0, 0.0), robot_base_yaw=0.0, floor_z=0.0, space=space,
                target=TargetQuery("can", "red", (0.06, 0.06, 0.12)))


def test_the_fine_map_holds_kept_and_later_frames_as_a_fresh_integration():
    spheres = panda_sphere_model(RobotConfig())
    occ = OccupancyMap(MapConfig(box_min=(0.3, 0.2, 0.0), box_max=(0.9, 0.8, 1.0), resolution=0.01))
    first, later = _frame(0.6, 0.5), _frame(0.62, 0.45)
    integrate_observation(occ, first, spheres, 2.0)
    model = HarnessModel(occ, spheres, RobotConfig(), _task(), frames=[first], max_range=2.0, fine_margin=0.1)
    pts = np.array([[0.6, 0.5, 0.4], [0.62, 0.52, 0.42]])
    a = model.fine_map(pts)
    assert a.resolution == pytest.approx(0.005)
    assert np.any(a.state == VoxelState.OCCUPIED) and np.any(a.state == VoxelState.FREE)
    model.observe(later, 2.0)  # an INSPECT frame: into the map and into the fine map's frames
    b = model.fine_map(pts)
    fresh = local_fine_map(occ, pts.min(0) - 0.1, pts.max(0) + 0.1, 2)
    for f in (first, later):
        integrate_observation(fresh, f, spheres, 2.0)
    assert b is a and np.array_equal(b.state, fresh.state)  # the kept map took only the later frame
    assert not np.array_equal(fresh.state, local_fine_map(occ, pts.min(0) - 0.1, pts.max(0) + 0.1, 2).state)
    assert HarnessModel(occ, spheres, RobotConfig(), _task()).fine_map(pts) is None  # no frames: no fine map
    with pytest.raises(CompassInputError, match="fine_margin"):
        HarnessModel(occ, spheres, RobotConfig(), _task(), frames=[], fine_margin=0.0)


def test_harness_inspection_reports_the_simulated_time_of_its_moves():
    import numpy as np
    from compass_manip.motion.timing import segment_durations
    from compass_manip.sim.grasp_inspect import HarnessInspection
    home = np.asarray(RobotConfig().q_home)
    a = np.repeat(home[None], 3, axis=0)
    a[1, 0], a[2, 0] = home[0] + 0.3, home[0] + 0.6
    b = np.repeat(a[-1:], 2, axis=0)
    b[1, 3] = home[3] + 0.4
    insp = HarnessInspection(a[-1], 2, 3, 2, (), (a, b))
    assert insp.motion_s == pytest.approx(segment_durations(a).sum() + segment_durations(b).sum())
    assert insp.motion_s > segment_durations(a).sum() > 0.0
    assert HarnessInspection(a[0], 0, 1, 0, (), ()).motion_s == 0.0
