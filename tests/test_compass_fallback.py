"""COMPASS's fallback gain box (`CompassConfig.fallback_box`): checked config, and a map whose
unknown voxels are those of the box only, seen obstacles kept."""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.exploration.compass import CompassConfig, CompassMethod
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState


@pytest.mark.parametrize("bad", [((0, 0, 0), (1, 1)), ((1, 0, 0), (0, 1, 1)), "box", ((0, 0, 0), (np.nan, 1, 1))])
def test_a_bad_fallback_box_is_refused_by_name(bad):
    with pytest.raises(CompassInputError, match="fallback_box"):
        replace(CompassConfig(), fallback_box=bad)


def test_the_fallback_map_keeps_unknown_space_only_inside_the_box():
    occ = OccupancyMap(MapConfig(resolution=0.05, box_min=(-1.0, -1.0, 0.0), box_max=(1.0, 1.0, 1.0)))
    occ.state[:] = VoxelState.UNKNOWN
    behind = occ.world_to_voxel(np.array([[-0.5, 0.0, 0.5]]))[0]
    occ.state[tuple(behind)] = VoxelState.OCCUPIED  # a seen obstacle behind the base
    config = replace(CompassConfig(), fallback_box=((0.0, -0.4, 0.0), (0.6, 0.4, 0.8)))
    method = SimpleNamespace(config=config, task=SimpleNamespace(robot_base_pos=(0.1, 0.0, 0.0)),
                             world=SimpleNamespace(occ=occ), _fallback=None)
    out = CompassMethod._fallback_map(method)
    centres = occ.voxel_centers()
    unknown = out.state == VoxelState.UNKNOWN
    assert unknown.any()
    inside = np.all((centres >= np.array([0.1, -0.4, 0.0]) - 0.05) & (centres <= np.array([0.7, 0.4, 0.8]) + 0.05),
                    axis=-1)
    assert not (unknown & ~inside).any()  # nothing unknown outside the box (one voxel of rounding)
    assert out.state[tuple(behind)] == VoxelState.OCCUPIED  # the obstacle still stops the rays
    off = replace(CompassConfig(), fallback_box=None)
    assert CompassMethod._fallback_map(SimpleNamespace(config=off)) is None  # off: the world's map
