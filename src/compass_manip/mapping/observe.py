"""The one sense -> map step: filter the robot's own body out of an observation and
integrate its depth into the occupancy map.

Works on anything with `depth`, `K`, `T_world_cam` and `q` (an `Observation` or a
simulator `Frame`): the robot's collision spheres posed at the observation's joint state
`q` [rad], inflated by `margin` [m], say which measured points lie on the robot.
"""
from __future__ import annotations

import numpy as np

from .occupancy import IntegrationStats, OccupancyMap
from .selffilter import SphereBodyFilter

#: Inflation [m] of the robot's spheres when filtering its own body out of depth images.
SELF_FILTER_MARGIN = 0.01


def self_filter(spheres, q, margin: float = SELF_FILTER_MARGIN) -> SphereBodyFilter:
    """A point filter flagging points on the robot at joint state q (7,) [rad]; spheres: a
    `robot.spheres.SphereModel`."""
    return SphereBodyFilter(spheres.sphere_centers(np.asarray(q, dtype=np.float64)[None])[0], spheres.radii,
                            margin=margin)


def integrate_observation(occ: OccupancyMap, obs, spheres, max_range: float,
                          margin: float = SELF_FILTER_MARGIN) -> IntegrationStats:
    """Integrate obs.depth [m] seen from obs.T_world_cam into occ up to max_range [m], with
    the robot's body at obs.q filtered out. Returns the map's `IntegrationStats`."""
    return occ.integrate(obs.depth, obs.K, obs.T_world_cam, max_range, point_filter=self_filter(spheres, obs.q, margin))
