"""Property-based sweep of the remaining Python API boundaries (configs, IK, frontiers,
distance field, self-filter, primitives): any junk value gives CompassInputError or a
result; nothing else may escape (found 104 untyped exceptions before this suite)."""
import dataclasses

import numpy as np
from hypothesis import given, strategies as st

from compass_manip.errors import CompassInputError
from compass_manip.mapping import distance as dist_mod
from compass_manip.mapping.frontiers import FrontierConfig, find_frontiers
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap
from compass_manip.mapping.selffilter import SphereBodyFilter
from compass_manip.motion.primitives import DistanceGrid, PrimitiveSet
from compass_manip.robot.ik import IKConfig, ik_look_at, ik_tcp
from compass_manip.robot.kinematics import PandaKinematics
from compass_manip.robot.model import Q_HOME

JUNK = st.sampled_from(["abc", None, [1, 2], np.nan, np.inf, -1, 0, True, 1e9, [[1, 2, 3]], {"a": 1}, 0.5, 3])
CONFIGS = [FrontierConfig, IKConfig, dist_mod.DistanceFieldConfig]
FIELDS = [(c, f.name) for c in CONFIGS for f in dataclasses.fields(c)]
OCC = OccupancyMap(MapConfig(box_min=(0, 0, 0), box_max=(0.2, 0.2, 0.2), resolution=0.02))
T_TCP = PandaKinematics().T_world_tcp(Q_HOME)

CALLS = {
    "SphereBodyFilter margin": lambda v: SphereBodyFilter(np.zeros((1, 3)), [0.1], margin=v),
    "SphereBodyFilter centres": lambda v: SphereBodyFilter(v, [0.1]),
    "SphereBodyFilter radii": lambda v: SphereBodyFilter(np.zeros((1, 3)), v),
    "ik_tcp n_q7": lambda v: ik_tcp(T_TCP, Q_HOME, n_q7=v),
    "ik_tcp pose": lambda v: ik_tcp(v, Q_HOME),
    "ik_tcp q_ref": lambda v: ik_tcp(T_TCP, v),
    "ik_look_at n_samples": lambda v: ik_look_at([0.5, 0, 0.3], 0.3, Q_HOME, n_samples=v),
    "ik_look_at max_polar_deg": lambda v: ik_look_at([0.5, 0, 0.3], 0.3, Q_HOME, max_polar_deg=v, n_samples=2),
    "ik_look_at rng": lambda v: ik_look_at([0.5, 0, 0.3], 0.3, Q_HOME, rng=v, n_samples=2),
    "ik_look_at distance": lambda v: ik_look_at([0.5, 0, 0.3], v, Q_HOME, n_samples=2),
    "find_frontiers config": lambda v: find_frontiers(OCC, v),
    "find_frontiers map": lambda v: find_frontiers(v),
    "PrimitiveSet boxes": lambda v: PrimitiveSet.from_lists(boxes=v),
    "PrimitiveSet box half extents": lambda v: PrimitiveSet.from_lists(boxes=[(np.eye(4), v)]),
    "PrimitiveSet sphere centre": lambda v: PrimitiveSet.from_lists(spheres=[(v, 0.1)]),
    "PrimitiveSet cylinder radius": lambda v: PrimitiveSet.from_lists(cylinders=[(np.eye(4), v, 0.1)]),
    "PrimitiveSet distance": lambda v: PrimitiveSet.empty().distance(v),
    "DistanceGrid resolution": lambda v: DistanceGrid(np.ones((2, 2, 2), np.float32), np.zeros(3), v),
    "DistanceGrid dist": lambda v: DistanceGrid(v, np.zeros(3), 0.1),
    "DistanceField.from_map config": lambda v: dist_mod.DistanceField.from_map(OCC, v),
    "DistanceField.from_map map": lambda v: dist_mod.DistanceField.from_map(v),
}


@given(field=st.sampled_from(FIELDS), value=JUNK)
def test_config_fields_typed_error_or_accepted(field, value):
    cls, name = field
    try:
        cls(**{name: value})
    except CompassInputError as exc:
        assert "\n" not in str(exc)


@given(call=st.sampled_from(sorted(CALLS)), value=JUNK)
def test_api_calls_typed_error_or_result(call, value):
    try:
        CALLS[call](value)
    except CompassInputError as exc:
        assert "\n" not in str(exc)


def test_a_huge_self_filter_margin_is_refused_not_allocated():
    import pytest

    with pytest.raises(CompassInputError, match="margin"):
        SphereBodyFilter(np.zeros((1, 3)), [0.1], margin=1e9)
