"""Property-based checks of the mapping boundaries: depth integration, information gain and
`.bt` files. Every call either raises CompassInputError (and leaves the map untouched) or
returns the result of the same call on clean input; nothing else may escape."""
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import assume, given, strategies as st

from compass_manip.errors import CompassInputError
from compass_manip.geometry import look_at
from compass_manip.mapping.infogain import info_gain
from compass_manip.mapping.occupancy import MapConfig, OccupancyMap, VoxelState
from compass_manip.mapping.octomap_io import read_bt, write_bt

CONFIG = MapConfig(box_min=(0.0, 0.0, 0.0), box_max=(0.4, 0.4, 0.4), resolution=0.02)
T_CAM = look_at([0.2, 0.2, 0.03], [0.21, 0.19, 0.4])

FLOAT_DTYPES = [np.float16, np.float32, np.float64]
OTHER_DTYPES = [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, bool, np.complex64]
SPECIALS = [np.nan, np.inf, -np.inf, 0.0, -1.0, 1e30, 0.25, 0.39]


def _K(W, H, f=None):
    f = float(W) if f is None else f
    return np.array([[f, 0.0, 0.5 * (W - 1)], [0.0, f, 0.5 * (H - 1)], [0.0, 0.0, 1.0]])


def _snapshot(occ):
    return occ.logodds.tobytes(), occ.state.tobytes()


@st.composite
def depth_images(draw, fault: str):
    """A depth image; with fault 'dtype' of a non-float dtype, with 'shape' not (H, W)."""
    H = draw(st.integers(1, 9))
    W = draw(st.integers(1, 9))
    base = draw(st.lists(st.sampled_from(SPECIALS) | st.floats(0.01, 0.6), min_size=H * W, max_size=H * W))
    dtype = draw(st.sampled_from(OTHER_DTYPES if fault == "dtype" else FLOAT_DTYPES))
    with np.errstate(invalid="ignore", over="ignore"):
        a = np.asarray(base, np.float64).reshape(H, W)
        if not np.issubdtype(np.dtype(dtype), np.floating):
            a = np.clip(np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0) * 1000.0, -100, 200)  # "millimetres"
        depth = a.astype(dtype)
    if fault == "shape":
        depth = draw(st.sampled_from([depth.ravel(), depth[..., None], depth[:0], depth[None]]))
    return depth


@st.composite
def intrinsics(draw, H, W, fault: bool):
    K = _K(W, H)
    if not fault:
        return draw(st.sampled_from([K, K.tolist()]))
    kind = draw(st.sampled_from(["skew", "transposed", "k22", "tiny_f", "nan", "shape", "shift", "string"]))
    if kind == "skew":
        K[0, 1] = draw(st.floats(0.01, 5.0))
    elif kind == "transposed":
        K = K.T.copy()
        assume(not np.array_equal(K, K.T))
    elif kind == "k22":
        K[2, 2] = 0.0
    elif kind == "tiny_f":
        K[0, 0] = 1e-12
    elif kind == "nan":
        K[draw(st.integers(0, 2)), draw(st.integers(0, 2))] = np.nan
    elif kind == "shape":
        K = K[:2]
    elif kind == "shift":
        K[0, 2] += draw(st.sampled_from([-1.0, 1.0])) * (0.2 * W + 2)
    else:
        K = "K"
    return K


GOOD_RANGES = [2.0, np.float32(2.0), np.int64(2), 1, np.float64(0.5)]
BAD_RANGES = [0.0, -1.0, np.nan, np.inf, "2", None, True, np.array([2.0]), np.bool_(True)]
FAULTS = ["none", "dtype", "shape", "K", "range"]


@given(fault=st.sampled_from(FAULTS), data=st.data())
def test_integrate_typed_error_or_same_result_and_no_change_on_rejection(fault, data):
    depth = data.draw(depth_images(fault))
    H, W = depth.shape if depth.ndim == 2 and depth.size else (3, 4)
    K = data.draw(intrinsics(H, W, fault == "K"))
    max_range = data.draw(st.sampled_from(BAD_RANGES if fault == "range" else GOOD_RANGES))
    occ = OccupancyMap(CONFIG)
    occ.set_box([0.1, 0.1, 0.1], [0.2, 0.2, 0.2], VoxelState.OCCUPIED)  # some prior state
    before = _snapshot(occ)
    try:
        stats = occ.integrate(depth, K, T_CAM, max_range)
    except CompassInputError as exc:
        assert fault != "none", f"valid input rejected: {exc}"
        assert _snapshot(occ) == before, "a rejected call changed the map"
        if fault == "dtype" and depth.dtype != bool and np.issubdtype(depth.dtype, np.integer):
            assert "metres" in str(exc) and "1000" in str(exc)
        return
    assert fault == "none", f"accepted a bad {fault}: dtype {depth.dtype}, shape {depth.shape}, K {K}, " \
                            f"max_range {max_range!r}"
    ref = OccupancyMap(CONFIG)
    ref.set_box([0.1, 0.1, 0.1], [0.2, 0.2, 0.2], VoxelState.OCCUPIED)
    ref_stats = ref.integrate(np.asarray(depth, np.float32), np.asarray(K, float), T_CAM, float(max_range))
    assert stats == ref_stats and _snapshot(occ) == _snapshot(ref)


def test_millimetre_depth_is_refused_with_the_conversion():
    occ = OccupancyMap(CONFIG)
    depth_m = np.full((6, 8), 0.3, np.float32)
    with pytest.raises(CompassInputError, match=r"int16.*astype\(np.float32\) / 1000"):
        occ.integrate((depth_m * 1000).astype(np.int16), _K(8, 6), T_CAM, 2.0)
    assert occ.counts().unknown == occ.state.size
    stats = occ.integrate((depth_m * 1000).astype(np.int16).astype(np.float32) / 1000, _K(8, 6), T_CAM,
                          np.float32(2.0))
    assert stats.n_hit_updates > 0


@pytest.mark.parametrize("case", ["transposed image", "double size", "half size", "skew", "K transposed",
                                  "K22 zero", "fx 1e-12", "bool depth"])
def test_depth_and_K_from_different_cameras_are_refused(case):
    occ = OccupancyMap(CONFIG)
    depth, K = np.full((12, 16), 0.3, np.float32), _K(16, 12)
    if case == "transposed image":
        depth = depth.T.copy()
    elif case == "double size":
        depth = np.full((24, 32), 0.3, np.float32)
    elif case == "half size":
        depth = depth[:6, :8].copy()
    elif case == "skew":
        K[0, 1] = 0.3
    elif case == "K transposed":
        K = K.T.copy()
    elif case == "K22 zero":
        K[2, 2] = 0.0
    elif case == "fx 1e-12":
        K[0, 0] = 1e-12
    else:
        depth = depth > 0
    with pytest.raises(CompassInputError, match="K|depth"):
        occ.integrate(depth, K, T_CAM, 2.0)
    assert occ.counts().unknown == occ.state.size
    assert occ.integrate(np.full((12, 16), 0.3, np.float32), _K(16, 12), T_CAM, 2.0).n_hit_updates > 0


@given(K_kind=st.sampled_from(["ok", "skew", "transposed", "tiny_f", "nan", "zero"]),
       max_range=st.sampled_from([1.0, np.float32(1.0), np.int64(1), 0.0, np.nan, "1", None]),
       rays=st.sampled_from([(4, 3), (0, 3), (4.0, 3), (4.5, 3), (np.inf, 3), "ab", (True, 3), (4, 3, 1)]))
def test_info_gain_typed_error_or_count(K_kind, max_range, rays):
    occ = OccupancyMap(CONFIG)
    K = _K(32, 24)
    if K_kind == "skew":
        K[0, 1] = 0.5
    elif K_kind == "transposed":
        K = K.T.copy()
    elif K_kind == "tiny_f":
        K[1, 1] = 1e-12
    elif K_kind == "nan":
        K[0, 2] = np.nan
    elif K_kind == "zero":
        K[2, 2] = 0.0
    ok_rays = rays in ((4, 3), (4.0, 3))
    ok_range = not isinstance(max_range, str) and max_range is not None and np.isfinite(max_range) and max_range > 0
    try:
        g = info_gain(occ, T_CAM, K, max_range, rays)
    except CompassInputError:
        assert not (K_kind == "ok" and ok_rays and ok_range)
        return
    assert K_kind == "ok" and ok_rays and ok_range
    assert isinstance(g, int) and g == info_gain(occ, T_CAM, _K(32, 24), 1.0, (4, 3)) and g > 0


# ----------------------------------------------------------------------------- .bt files
@pytest.fixture(scope="module")
def bt_bytes(tmp_path_factory) -> bytes:
    occ = OccupancyMap(CONFIG)
    rng = np.random.default_rng(0)
    idx = rng.integers(0, occ.shape[0], size=(300, 3))
    occ.set_voxels(idx[:150], VoxelState.FREE)
    occ.set_voxels(idx[150:], VoxelState.OCCUPIED)
    occ.set_box([0.0, 0.0, 0.0], [0.16, 0.16, 0.16], VoxelState.FREE)  # prunes into large leaves
    path = tmp_path_factory.mktemp("bt") / "map.bt"
    write_bt(occ, path)
    return path.read_bytes()


def _read(tmp_path, blob, name="x.bt"):
    p = tmp_path / name
    p.write_bytes(blob)
    return read_bt(p, CONFIG)


@given(cut=st.integers(0, 10_000))
def test_truncated_bt_always_raises(tmp_path_factory, bt_bytes, cut):
    cut = cut % len(bt_bytes)
    with pytest.raises(CompassInputError):
        _read(tmp_path_factory.mktemp("cut"), bt_bytes[:cut])


@given(edits=st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)), min_size=1, max_size=8),
       extra=st.binary(max_size=64))
def test_corrupted_bt_typed_error_or_bounded_map(tmp_path_factory, bt_bytes, edits, extra):
    blob = bytearray(bt_bytes)
    for pos, val in edits:
        blob[pos % len(blob)] = val
    blob = bytes(blob) + extra
    try:
        occ = _read(tmp_path_factory.mktemp("bad"), blob)
    except CompassInputError as exc:
        assert "\n" not in str(exc)
        return
    assert occ.shape == OccupancyMap(CONFIG).shape and set(np.unique(occ.state)) <= {0, 1, 2}


@given(blob=st.binary(max_size=512) | st.text(max_size=200).map(str.encode))
def test_random_files_are_not_octomap_files(tmp_path_factory, blob):
    with pytest.raises(CompassInputError):
        _read(tmp_path_factory.mktemp("rnd"), blob)


def test_bt_round_trip_and_named_errors(tmp_path, bt_bytes):
    occ = _read(tmp_path, bt_bytes)
    assert occ.counts().free > 512 and occ.counts().occupied > 50
    with pytest.raises(CompassInputError, match="empty"):
        _read(tmp_path, b"", "empty.bt")
    with pytest.raises(CompassInputError, match="not an OctoMap binary file"):
        _read(tmp_path, b"hello\n", "text.bt")
    with pytest.raises(CompassInputError, match="cut off"):
        _read(tmp_path, bt_bytes[:-1], "cut.bt")
    with pytest.raises(CompassInputError, match="res 0.02 m differs"):
        read_bt(tmp_path / "x.bt", MapConfig(**{**CONFIG.__dict__, "resolution": 0.01}))
    with pytest.raises(CompassInputError, match="does not exist"):
        read_bt(tmp_path / "missing.bt", CONFIG)


def test_huge_leaves_are_clipped_to_the_grid(tmp_path):
    # root with 8 leaf children: each leaf spans 2^15 voxels per side (a 3e13-voxel box)
    hdr = b"# Octomap OcTree binary file\nid OcTree\nsize 9\nres 0.02\ndata\n"
    occ = _read(tmp_path, hdr + bytes([0x55, 0xAA]))  # children 0-3 free, 4-7 occupied
    assert occ.counts().occupied == occ.state.size  # the box lies in child 7 (+x, +y, +z)
    straddle = MapConfig(box_min=(-0.2, -0.2, -0.2), box_max=(0.2, 0.2, 0.2), resolution=0.02)
    c = read_bt(tmp_path / "x.bt", straddle).counts()
    assert c.unknown == 0 and c.free == c.occupied == 4000


def test_random_tail_after_a_valid_header_stays_within_memory(tmp_path):
    """The reported reproduction: header + 3 KB of random bytes once asked for 32 TiB."""
    code = (
        "import resource, os, numpy as np\n"
        "resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))\n"
        "from compass_manip.errors import CompassInputError\n"
        "from compass_manip.mapping.occupancy import MapConfig\n"
        "from compass_manip.mapping.octomap_io import read_bt\n"
        "rng = np.random.default_rng(1); n_err = 0\n"
        "for i in range(40):\n"
        "    p = os.path.join(os.environ['OUT'], f'r{i}.bt')\n"
        "    open(p, 'wb').write(b'# Octomap OcTree binary file\\nid OcTree\\nsize 100\\nres 0.1\\ndata\\n' +\n"
        "                       rng.integers(0, 256, 3000, dtype=np.uint8).tobytes())\n"
        "    try:\n"
        "        read_bt(p, MapConfig(resolution=0.1))\n"
        "    except CompassInputError:\n"
        "        n_err += 1\n"
        "print(n_err)\n"
    )
    env = {**os.environ, "OUT": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "40"


JUNK = st.sampled_from(["abc", None, [1, 2], [[1, 2, 3], [1, 2]], {"x": 1}, np.nan, [np.nan] * 3, True, object(),
                        [1.0, 2.0, 3.0], np.zeros((2, 3)), 0.0, -1.0, 7])


@given(field=st.sampled_from(["box_min", "box_max", "resolution", "prob_hit", "prob_miss", "clamp_min",
                              "clamp_max", "occupancy_threshold", "pixel_stride", "ray_grouping"]), value=JUNK)
def test_map_config_fields_typed_error_or_valid(field, value):
    try:
        config = MapConfig(**{**CONFIG.__dict__, field: value})
    except CompassInputError:
        return
    OccupancyMap(config)  # an accepted config builds a map


@given(call=st.sampled_from(["set_voxels", "set_box", "state_at", "world_to_voxel", "known_fraction",
                             "integrate_points"]), a=JUNK, b=JUNK)
def test_map_methods_typed_error_and_no_change(call, a, b):
    occ = OccupancyMap(CONFIG)
    occ.set_box([0.1, 0.1, 0.1], [0.2, 0.2, 0.2], VoxelState.FREE)
    before = _snapshot(occ)
    f = {"set_voxels": lambda: occ.set_voxels(a, b), "set_box": lambda: occ.set_box(a, [0.3] * 3, b),
         "state_at": lambda: occ.state_at(a), "world_to_voxel": lambda: occ.world_to_voxel(a),
         "known_fraction": lambda: occ.known_fraction(a, b), "integrate_points": lambda: occ.integrate_points(a, b)}
    try:
        f[call]()
    except CompassInputError:
        assert _snapshot(occ) == before, "a rejected call changed the map"
