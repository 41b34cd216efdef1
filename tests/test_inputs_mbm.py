"""Property-based checks of the MotionBenchMaker reader and `compass mbm`: YAML that parses
with wrong types, NaN or inf joints, files cut off, bytes that are not UTF-8, bad CLI
arguments. Every case gives CompassInputError (one line, exit 2 from the CLI) or problems
whose every number is finite and well formed; nothing else may escape."""
import copy
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml
from hypothesis import given, strategies as st

from compass_manip.bench.mbm_io import load_problems
from compass_manip.cli import main
from compass_manip.paths import check_output_dir, check_output_file
from compass_manip.errors import CompassInputError

JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
SCENE = {
    "name": "tiny",
    "world": {"collision_objects": [
        {"id": "shelf", "pose": {"position": [0.6, 0.0, 0.3], "orientation": [0, 0, 0, 1]},
         "primitives": [{"type": "box", "dimensions": [0.3, 0.6, 0.02]},
                        {"type": "cylinder", "dimensions": [0.14, 0.03]}],
         "primitive_poses": [{"position": [0, 0, 0], "orientation": [0, 0, 0, 1]},
                             {"position": {"x": 0, "y": 0.1, "z": 0.08}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}]},
        {"id": "ball", "primitives": [{"type": "sphere", "dimensions": [0.05]}],
         "primitive_poses": [{"position": [0.5, -0.3, 0.6]}]},
    ]},
}
REQUEST = {
    "start_state": {"joint_state": {"name": JOINTS + ["panda_finger_joint1", "panda_finger_joint2"],
                                    "position": [0, -0.785, 0, -2.356, 0, 1.571, 0.785, 0.035, 0.035]}},
    "goal_constraints": [{"joint_constraints": [{"joint_name": j, "position": v}
                                                for j, v in zip(JOINTS, [0.5, -0.5, 0, -2.0, 0, 1.5, 0.7])]}],
}
#: Values that parse as YAML but are wrong in most places.
JUNK = st.sampled_from(["abc", "", None, True, [], {}, [1, 2], {"x": 1}, float("nan"), float("inf"), -1e300, 0,
                        -0.0, [["a"]], "0.5"])


def _paths(node, prefix=()):
    """Every key / index path of a nested YAML document."""
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _set(doc, path, value):
    if not path:
        return value
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return doc


SCENE_PATHS = list(_paths(SCENE))
REQUEST_PATHS = list(_paths(REQUEST))


def _write(folder, scene_text, request_text):
    os.makedirs(folder, exist_ok=True)
    for name, text in (("scene0001.yaml", scene_text), ("request0001.yaml", request_text)):
        with open(os.path.join(folder, name), "wb") as fh:
            fh.write(text if isinstance(text, bytes) else text.encode())
    return folder


def _check_problem(p):
    assert p.q_start.shape == (7,) and np.all(np.isfinite(p.q_start))
    assert p.q_goals.ndim == 2 and p.q_goals.shape[1] == 7 and np.all(np.isfinite(p.q_goals))
    for T, half in p.boxes:
        assert np.all(np.isfinite(T)) and np.all(half > 0)
    for T, r, h in p.cylinders:
        assert np.all(np.isfinite(T)) and r > 0 and h > 0
    for c, r in p.spheres:
        assert np.all(np.isfinite(c)) and r > 0
    assert np.isfinite(p.finger_width)


def test_the_clean_documents_load(tmp_path):
    (p,) = load_problems(_write(str(tmp_path / "clean"), yaml.safe_dump(SCENE), yaml.safe_dump(REQUEST)))
    _check_problem(p)
    assert (len(p.boxes), len(p.cylinders), len(p.spheres)) == (1, 1, 1)
    assert p.finger_width == pytest.approx(0.07)


@given(which=st.sampled_from(["scene", "request"]), data=st.data(), value=JUNK)
def test_wrong_yaml_types_give_a_typed_error_or_finite_problems(tmp_path_factory, which, data, value):
    paths = SCENE_PATHS if which == "scene" else REQUEST_PATHS
    path = data.draw(st.sampled_from(paths))
    scene, request = copy.deepcopy(SCENE), copy.deepcopy(REQUEST)
    if which == "scene":
        scene = _set(scene, path, value)
    else:
        request = _set(request, path, value)
    folder = _write(str(tmp_path_factory.mktemp("mbm")), yaml.safe_dump(scene), yaml.safe_dump(request))
    try:
        problems = load_problems(folder)
    except CompassInputError as exc:
        msg = str(exc)
        assert "\n" not in msg and ("scene0001" in msg or "request0001" in msg), msg
        return
    for p in problems:
        _check_problem(p)


@pytest.mark.parametrize("joint", [0, 3, 6])
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), "abc"])
@pytest.mark.parametrize("where", ["start", "goal"])
def test_nan_inf_or_text_joint_is_an_error_naming_file_and_key(tmp_path, joint, bad, where):
    request = copy.deepcopy(REQUEST)
    if where == "start":
        request["start_state"]["joint_state"]["position"][joint] = bad
    else:
        request["goal_constraints"][0]["joint_constraints"][joint]["position"] = bad
    folder = _write(str(tmp_path), yaml.safe_dump(SCENE), yaml.safe_dump(request))
    with pytest.raises(CompassInputError, match=rf"request0001.yaml: .*panda_joint{joint + 1}.* is not allowed"):
        load_problems(folder)


@given(cut=st.integers(0, 100_000))
def test_scene_cut_off_is_an_error_or_a_prefix_that_still_has_its_world(tmp_path_factory, cut):
    text = yaml.safe_dump(SCENE)
    cut = cut % len(text)
    folder = _write(str(tmp_path_factory.mktemp("cut")), text[:cut], yaml.safe_dump(REQUEST))
    try:
        (p,) = load_problems(folder)
    except CompassInputError:
        return
    assert "world:" in text[:cut]  # never solved as a problem without obstacles
    _check_problem(p)
    assert len(p.boxes) + len(p.cylinders) + len(p.spheres) >= 1


def test_scene_without_world_and_zero_size_box_name_the_file(tmp_path):
    scene = {k: v for k, v in SCENE.items() if k != "world"}
    with pytest.raises(CompassInputError, match=r"scene0001.yaml has no 'world' key"):
        load_problems(_write(str(tmp_path / "a"), yaml.safe_dump(scene), yaml.safe_dump(REQUEST)))
    scene = copy.deepcopy(SCENE)
    scene["world"]["collision_objects"][0]["primitives"][0]["dimensions"] = [0.3, 0.0, 0.02]
    with pytest.raises(CompassInputError, match=r"scene0001.yaml: object 'shelf': box dimensions"):
        load_problems(_write(str(tmp_path / "b"), yaml.safe_dump(scene), yaml.safe_dump(REQUEST)))


@given(junk=st.binary(min_size=1, max_size=64))
def test_non_utf8_and_random_bytes_give_a_typed_error(tmp_path_factory, junk):
    folder = _write(str(tmp_path_factory.mktemp("bytes")), b"\xff\xfe" + junk, yaml.safe_dump(REQUEST))
    with pytest.raises(CompassInputError):
        load_problems(folder)


# ----------------------------------------------------------------------------- the CLI
BAD_ARGS = [
    ["--seed=-1"], ["--seed", "abc"], ["--time-budget", "nan"], ["--time-budget", "0"], ["--time-budget", "-1"],
    ["--time-budget", "inf"], ["--resolution", "0"], ["--resolution", "nan"], ["--validate-resolution", "0"],
    ["--validate-resolution", "1"], ["--backend", "vamp"], ["--no-such-flag"],
]


@pytest.fixture(scope="module")
def tiny_set(tmp_path_factory):
    return _write(str(tmp_path_factory.mktemp("tiny")), yaml.safe_dump(SCENE), yaml.safe_dump(REQUEST))


def _run_cli(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("args", BAD_ARGS, ids=lambda a: " ".join(a))
def test_cli_bad_arguments_one_line_exit_2(tiny_set, capsys, args):
    code, out, err = _run_cli(["mbm", tiny_set, "--no-progress", *args], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "error" in err and "Traceback" not in err, err


@pytest.mark.parametrize("kind", ["missing", "garbage.tar.bz2", "not-utf8", "nan-start", "no-world", "empty-dir",
                                  "text-file"])
def test_cli_bad_problem_sets_one_line_exit_2(tmp_path, capsys, kind):
    path = tmp_path / kind
    if kind == "garbage.tar.bz2":
        path.write_bytes(b"BZh9 not really")
    elif kind == "not-utf8":
        _write(str(path), b"world: {collision_objects: []}\n# \xff\xfe\n", yaml.safe_dump(REQUEST))
    elif kind == "nan-start":
        request = copy.deepcopy(REQUEST)
        request["start_state"]["joint_state"]["position"][0] = float("nan")
        _write(str(path), yaml.safe_dump(SCENE), yaml.safe_dump(request))
    elif kind == "no-world":
        _write(str(path), "name: cut\nrobot_state: {}\n", yaml.safe_dump(REQUEST))
    elif kind == "empty-dir":
        path.mkdir()
    elif kind == "text-file":
        path.write_text("hello")
    code, out, err = _run_cli(["mbm", str(path), "--no-progress"], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("compass mbm: error: ") and "Traceback" not in err, err


def test_cli_seed_minus_one_in_a_fresh_process(tiny_set):
    """The whole program, as a user runs it: one line on stderr, exit 2, no traceback."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    r = subprocess.run([sys.executable, "-m", "compass_manip.cli", "mbm", tiny_set, "--seed=-1"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip().count("\n") == 0 and "--seed -1" in r.stderr and "Traceback" not in r.stderr


# ----------------------------------------------------------------------------- --out paths
def _one_line_error(call):
    with pytest.raises(CompassInputError) as info:
        call()
    assert "\n" not in str(info.value)
    return str(info.value)


def test_check_output_dir_accepts_new_and_existing_folders(tmp_path):
    new = tmp_path / "a" / "b"
    assert check_output_dir(str(new)) == str(new) and new.is_dir()
    assert check_output_dir(new) == str(new)  # existing folder, PathLike


def test_check_output_dir_refuses_what_cannot_be_written(tmp_path):
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert "existing file" in _one_line_error(lambda: check_output_dir(str(f)))
    assert "under the file" in _one_line_error(lambda: check_output_dir(str(f / "sub" / "dir")))
    assert "/proc" in _one_line_error(lambda: check_output_dir("/proc"))  # exists, not writable even for root
    assert "/proc/compass" in _one_line_error(lambda: check_output_dir("/proc/compass"))
    assert "empty" in _one_line_error(lambda: check_output_dir(""))
    msg = _one_line_error(lambda: check_output_dir("/proc", option="--out"))
    assert msg.startswith("--out '/proc'")


def test_check_output_dir_read_only_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.geteuid() == 0:  # root may write anyway: the probe write decides, so it is accepted
            assert check_output_dir(str(ro)) == str(ro)
            assert list(ro.iterdir()) == []  # the probe file is removed
        else:
            assert "not writable" in _one_line_error(lambda: check_output_dir(str(ro)))
            assert "cannot be created" in _one_line_error(lambda: check_output_dir(str(ro / "sub")))
    finally:
        ro.chmod(0o755)


def test_check_output_file(tmp_path):
    assert check_output_file(str(tmp_path / "map.bt")) == str(tmp_path / "map.bt")
    assert "is a folder" in _one_line_error(lambda: check_output_file(str(tmp_path)))
    assert "does not exist" in _one_line_error(lambda: check_output_file(str(tmp_path / "no" / "map.bt")))
    assert "not writable" in _one_line_error(lambda: check_output_file("/proc/map.bt"))


def test_degrees_and_millimetres_are_refused(tmp_path):
    request = copy.deepcopy(REQUEST)
    request["start_state"]["joint_state"]["position"][:7] = np.degrees([0, -0.785, 0, -2.356, 0, 1.571, 0.785]).tolist()
    with pytest.raises(CompassInputError, match=r"request0001.yaml: start state joint value -44.97.* \(degrees\?\)"):
        load_problems(_write(str(tmp_path / "a"), yaml.safe_dump(SCENE), yaml.safe_dump(request)))
    scene = copy.deepcopy(SCENE)
    scene["world"]["collision_objects"][0]["primitives"][0]["dimensions"] = [300, 600, 20]
    with pytest.raises(CompassInputError, match=r"scene0001.yaml: object 'shelf': box .*\(millimetres\?\)"):
        load_problems(_write(str(tmp_path / "b"), yaml.safe_dump(scene), yaml.safe_dump(REQUEST)))


def test_oversized_member_of_an_archive_is_refused_before_reading(tmp_path):
    import io
    import tarfile

    from compass_manip.bench import mbm_io

    path = tmp_path / "bomb.tar.bz2"
    with tarfile.open(path, "w:bz2") as tar:
        data = b"#" * (mbm_io.MAX_FILE_BYTES + 1)  # compresses to a few hundred bytes
        info = tarfile.TarInfo("problems/x_panda/scene0001.yaml")
        info.size = len(data)
        tar.addfile(info, io.BytesIO(data))
    assert path.stat().st_size < 100_000
    with pytest.raises(CompassInputError, match="too large"):
        load_problems(str(path))


@pytest.mark.parametrize("where", ["/proc", "file", "under-file", "/proc/new"])
def test_out_helper_through_the_cli_one_line_exit_2_before_any_work(tmp_path, capsys, monkeypatch, where):
    """A subcommand calling check_output_dir first, as `compass scenes` / `compass demo` do:
    a bad --out is one error line with exit 2 and no work is done."""
    import types

    import compass_manip.cli as cli

    work = []
    probe = types.ModuleType("compass_manip.cli._out_probe")
    probe.HELP = "test subcommand"
    probe.add_arguments = lambda p: p.add_argument("--out", required=True)

    def run(args):
        check_output_dir(args.out)
        work.append(args.out)  # the expensive part would start here
        return 0

    probe.run = run
    monkeypatch.setitem(sys.modules, "compass_manip.cli._out_probe", probe)
    monkeypatch.setitem(cli.SUBCOMMANDS, "outprobe", "_out_probe")
    f = tmp_path / "file.txt"
    f.write_text("x")
    out = {"/proc": "/proc", "file": str(f), "under-file": str(f / "sub"), "/proc/new": "/proc/new"}[where]
    code, stdout, err = _run_cli(["outprobe", "--out", out], capsys)
    assert code == 2 and stdout == "" and work == []
    assert err.count("\n") == 1 and err.startswith("compass outprobe: error: --out ") and "Traceback" not in err
    code, _, _ = _run_cli(["outprobe", "--out", str(tmp_path / "new")], capsys)
    assert code == 0 and work == [str(tmp_path / "new")]
