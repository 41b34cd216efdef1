"""IG formulations (Isler et al. 2016) on a hand-built map: one ray along +x through a row
of voxels with known states and log-odds; the values are computed by hand below."""
import math

import numpy as np
import pytest

from compass_manip.exploration.greedy_ig import GreedyIGConfig
from compass_manip.exploration.ig_formulations import IGFormulation, binary_entropy, roi_mask, view_information
from compass_manip.errors import CompassInputError
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState

# one ray: a 21 x 21 px image whose principal point is its centre, rays=(1, 1) -> the optical axis
K = np.array([[100.0, 0, 10], [0, 100.0, 10], [0, 0, 1]])


def _corridor():
    """10 x 3 x 3 voxels of 0.1 m; along the row j = k = 1: 0 free (camera), 1 unknown,
    2 free, 3 unknown, 4 occupied, 5..9 unknown. ROI: voxels 1..6 of the row."""
    occ = OccupancyMap(MapConfig(box_min=(0, 0, 0), box_max=(1.0, 0.3, 0.3), resolution=0.1))
    occ.set_box((0, 0, 0), (1.0, 0.3, 0.3), VoxelState.FREE)
    row = lambda i: np.array([[i, 1, 1]])  # noqa: E731
    for i in (1, 3, 5, 6, 7, 8, 9):
        occ.set_voxels(row(i), VoxelState.UNKNOWN)
    occ.set_voxels(row(4), VoxelState.OCCUPIED)
    roi = roi_mask(occ, (0.1, 0.1, 0.1), (0.69, 0.2, 0.2))
    # camera at the centre of voxel 0, optical axis (+z of the camera) along world +x
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = (0, -1, 0), (0, 0, -1), (1, 0, 0)
    T[:3, 3] = (0.05, 0.15, 0.15)
    return occ, roi, T


def test_roi_holds_voxels_one_to_six_of_the_row():
    occ, roi, _ = _corridor()
    assert roi.sum() == 6 and roi[1:7, 1, 1].all()


def test_unobserved_voxel_count_stops_at_the_first_occupied_voxel():
    occ, roi, T = _corridor()
    # range 0.8 m: voxels 0..7 visited; unknown in the ROI before voxel 4: voxels 1 and 3
    v = view_information(occ, roi, T[None], K, 0.8, (1, 1), IGFormulation.UNOBSERVED)
    assert v.tolist() == [2.0]
    # a shorter range (0.3 m) ends the ray before voxel 3
    assert view_information(occ, roi, T[None], K, 0.3, (1, 1), IGFormulation.UNOBSERVED).tolist() == [1.0]


def test_occlusion_aware_is_visibility_weighted_entropy():
    occ, roi, T = _corridor()
    p_free, p_occ = 0.12, 0.97  # the map's clamping probabilities (set_voxels)
    h = lambda p: -(p * math.log2(p) + (1 - p) * math.log2(1 - p))  # noqa: E731
    vis, total = 1.0, 0.0
    # voxel 0: outside the ROI, free -> transparent, no information
    for p in (0.5, p_free, 0.5, p_occ, 0.5, 0.5):  # voxels 1..6, in the ROI
        total += vis * h(p)
        vis *= 1 - p
    # voxel 7: outside the ROI and unknown -> transparent, no information
    v = view_information(occ, roi, T[None], K, 0.8, (1, 1), IGFormulation.OCCLUSION_AWARE, p_unknown=0.5,
                         min_visibility=1e-9)
    assert v[0] == pytest.approx(total, rel=1e-5)
    assert total == pytest.approx(1 + 0.5 * h(0.12) + 0.44 + 0.22 * h(0.97) + 0.0066 + 0.0033, rel=1e-6)
    # a visibility floor above P_v after the occupied voxel (0.0066) cuts the ray there
    v2 = view_information(occ, roi, T[None], K, 0.8, (1, 1), IGFormulation.OCCLUSION_AWARE, min_visibility=0.01)
    assert v2[0] == pytest.approx(1 + 0.5 * h(0.12) + 0.44 + 0.22 * h(0.97), rel=1e-5)


def test_information_is_summed_per_ray():
    occ, roi, T = _corridor()
    # three rays down the image (v = 3, 10, 17 px): 4 deg apart, all three stay in the row up
    # to the occupied voxel (z deviates < 0.03 m there), so each counts voxels 1 and 3: 3 x 2
    assert view_information(occ, roi, T[None], K, 0.8, (1, 3), IGFormulation.UNOBSERVED).tolist() == [6.0]
    both = view_information(occ, roi, np.stack([T, T]), K, 0.8, (1, 1), IGFormulation.UNOBSERVED)
    assert both.tolist() == [2.0, 2.0]


def test_binary_entropy_values():
    np.testing.assert_allclose(binary_entropy([0.5, 0.0, 1.0, 0.25]), [1.0, 0.0, 0.0, 0.8112781], atol=1e-6)


def test_config_rejects_bad_values():
    with pytest.raises(CompassInputError):
        GreedyIGConfig(radius=(0.5, 0.2))
    with pytest.raises(CompassInputError):
        GreedyIGConfig(n_views=0)
