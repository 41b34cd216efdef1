"""MotionBenchMaker problems: MoveIt planning scenes + motion plan requests as plain arrays.

A problem set is a directory, or a `.tar.bz2` archive, holding `sceneNNNN.yaml` and
`requestNNNN.yaml` pairs, either directly or in one sub-folder per family (e.g.
`problems/box_panda/`). Scenes are MoveIt `PlanningScene` messages in YAML: collision
objects made of box (full sizes x, y, z [m]), cylinder (height, radius [m]) and sphere
(radius [m]) primitives with poses in the world (position [m], orientation quaternion
x, y, z, w); the robot base is at the world origin. Requests are MoveIt
`MotionPlanRequest`s: a start joint state and joint-space goal constraints [rad]; the
finger opening [m] is the sum of the start state's two finger joints (the shared Panda
requests set each to 0.065 m: 0.13 m), and each problem is checked with that opening.
Solving them is `bench.mbm`.
"""
from __future__ import annotations

import os
import re
import tarfile
from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError
from ..geometry import make_T, quat_to_R
from ..robot.kinematics import MAX_FINGER_WIDTH
from ..robot.model import ARM_JOINTS, GRIPPER_MAX_WIDTH, N_ARM_JOINTS

_SCENE_RE = re.compile(r"scene(\d+)\.ya?ml$")
_REQUEST_RE = re.compile(r"request(\d+)\.ya?ml$")


@dataclass(frozen=True)
class MbmProblem:
    """One problem. Obstacles in the world frame: boxes as (T_world_box (4,4), half extents
    (3,) [m]), cylinders as (T_world_cyl (4,4) with the axis along local z, radius [m], half
    length [m]), spheres as (center (3,) [m], radius [m]). q_start [rad] (7,), q_goals [rad]
    (k,7): any goal may be reached; finger_width [m]: opening of the fingers (distance between
    them) in the start state."""

    family: str
    name: str
    boxes: tuple
    cylinders: tuple
    spheres: tuple
    q_start: np.ndarray
    q_goals: np.ndarray
    obstacle_ids: tuple = ()  # object id of each box, then cylinder, then sphere
    finger_width: float = GRIPPER_MAX_WIDTH

    def primitive_lists(self) -> dict:
        """Keyword arguments for `PrimitiveSet.from_lists(boxes=, spheres=, cylinders=)`."""
        return {"boxes": list(self.boxes), "spheres": list(self.spheres), "cylinders": list(self.cylinders)}


def _yaml_load(text: str, where: str):
    import yaml

    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    try:
        return yaml.load(text, Loader=loader)
    except yaml.YAMLError as exc:
        raise CompassInputError(f"{where} is not valid YAML: {str(exc).splitlines()[0]}") from exc


def _vec(value, keys: str, where: str) -> np.ndarray:
    """A position or quaternion given as a list or as a mapping {x:, y:, z:(, w:)}."""
    if isinstance(value, dict):
        value = [value.get(k) for k in keys]
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{where}: cannot read {value!r} as numbers") from exc
    if v.shape != (len(keys),) or not np.all(np.isfinite(v)):
        raise CompassInputError(f"{where}: expected {len(keys)} finite numbers ({keys}), got {value!r}")
    return v


def _pose(pose: dict | None, where: str) -> np.ndarray:
    if not pose:
        return np.eye(4)
    xyzw = _vec(pose.get("orientation", [0, 0, 0, 1]), "xyzw", f"{where} orientation")
    n = np.linalg.norm(xyzw)
    if n < 1e-9:
        raise CompassInputError(f"{where}: zero quaternion")
    x, y, z, w = xyzw / n
    return make_T(quat_to_R([w, x, y, z]), _vec(pose.get("position", [0, 0, 0]), "xyz", f"{where} position"))


def parse_scene(data: dict, where: str) -> tuple[tuple, tuple, tuple, tuple]:
    """(boxes, cylinders, spheres, obstacle ids) of a MoveIt planning scene mapping; see
    MbmProblem."""
    if not isinstance(data, dict):
        raise CompassInputError(f"{where} is not a MoveIt planning scene (no mapping at top level)")
    objects = ((data.get("world") or {}).get("collision_objects")) or []
    boxes, cylinders, spheres = [], [], []
    ids: dict[str, list] = {"box": [], "cylinder": [], "sphere": []}
    for obj in objects:
        oid = obj.get("id", "?")
        if obj.get("operation") in (1, 2, "remove", "REMOVE"):
            continue
        if obj.get("meshes") or obj.get("planes"):
            raise CompassInputError(f"{where}: object {oid!r} has meshes or planes; only box, cylinder, sphere are supported")
        T_world_obj = _pose(obj.get("pose"), f"{where} object {oid!r} pose")
        prims = obj.get("primitives") or []
        poses = obj.get("primitive_poses") or []
        if len(prims) != len(poses):
            raise CompassInputError(f"{where}: object {oid!r} has {len(prims)} primitives but {len(poses)} poses")
        for prim, pose in zip(prims, poses):
            T = T_world_obj @ _pose(pose, f"{where} object {oid!r}")
            kind = str(prim.get("type", "")).lower()
            dims = np.asarray(prim.get("dimensions", []), dtype=np.float64)
            if kind in ("box", "1"):
                if dims.shape != (3,):
                    raise CompassInputError(f"{where}: box {oid!r} needs 3 dimensions [m], got {dims.tolist()}")
                boxes.append((T, 0.5 * dims))
                ids["box"].append(str(oid))
            elif kind in ("cylinder", "3"):
                if dims.shape != (2,):
                    raise CompassInputError(f"{where}: cylinder {oid!r} needs [height, radius] [m], got {dims.tolist()}")
                cylinders.append((T, float(dims[1]), 0.5 * float(dims[0])))
                ids["cylinder"].append(str(oid))
            elif kind in ("sphere", "2"):
                if dims.shape != (1,):
                    raise CompassInputError(f"{where}: sphere {oid!r} needs [radius] [m], got {dims.tolist()}")
                spheres.append((T[:3, 3].copy(), float(dims[0])))
                ids["sphere"].append(str(oid))
            else:
                raise CompassInputError(f"{where}: primitive type {kind!r} of {oid!r} is not supported; use box, cylinder or sphere")
    return tuple(boxes), tuple(cylinders), tuple(spheres), tuple(ids["box"] + ids["cylinder"] + ids["sphere"])


def parse_request(data: dict, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(q_start (7,), q_goals (k,7)) [rad] of a MoveIt motion plan request mapping."""
    if not isinstance(data, dict):
        raise CompassInputError(f"{where} is not a MoveIt motion plan request (no mapping at top level)")
    js = ((data.get("start_state") or {}).get("joint_state")) or {}
    names, pos = list(js.get("name") or []), list(js.get("position") or [])
    start = dict(zip(names, pos))
    missing = [j for j in ARM_JOINTS if j not in start]
    if missing:
        raise CompassInputError(f"{where}: start state lacks joints {missing}")
    q_start = np.array([start[j] for j in ARM_JOINTS], dtype=np.float64)
    goals = []
    for gc in data.get("goal_constraints") or []:
        jc = {c.get("joint_name"): c.get("position") for c in gc.get("joint_constraints") or []}
        if all(j in jc for j in ARM_JOINTS):
            goals.append([jc[j] for j in ARM_JOINTS])
    if not goals:
        raise CompassInputError(f"{where}: no joint-space goal constraint covering {ARM_JOINTS[0]}..{ARM_JOINTS[-1]}")
    return q_start, np.asarray(goals, dtype=np.float64).reshape(-1, N_ARM_JOINTS)


def parse_finger_width(data: dict, where: str) -> float:
    """Finger opening [m] of a request's start state: the sum of its two finger joints
    (`*finger_joint1`, `*finger_joint2`); GRIPPER_MAX_WIDTH when it names no finger joint."""
    js = ((data.get("start_state") or {}).get("joint_state")) or {}
    start = dict(zip(list(js.get("name") or []), list(js.get("position") or [])))
    fingers = [v for k in ("finger_joint1", "finger_joint2") for n, v in start.items() if str(n).endswith(k)]
    if not fingers:
        return GRIPPER_MAX_WIDTH
    try:
        width = float(sum(float(v) for v in fingers)) * (2.0 / len(fingers))
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{where}: finger joint positions {fingers!r} are not numbers") from exc
    if not (np.isfinite(width) and 0.0 <= width <= MAX_FINGER_WIDTH):
        raise CompassInputError(f"{where}: finger opening {width} m (sum of the finger joints) is not allowed; "
                                f"use 0..{MAX_FINGER_WIDTH} m")
    return width


def _family_name(folder: str, root_name: str) -> str:
    name = os.path.basename(folder.rstrip("/")) or root_name
    return name[: -len("_panda")] if name.endswith("_panda") else name


def _read_files(path: str) -> tuple[dict[str, str], str]:
    """{relative path: text} of the YAML files under a directory or in a .tar.bz2 archive."""
    if not os.path.exists(path):
        raise CompassInputError(f"{path}: no such file or directory; give a folder or .tar.bz2 of MotionBenchMaker problems")
    root_name = os.path.basename(os.path.normpath(path))
    files: dict[str, str] = {}
    if os.path.isdir(path):
        for dirpath, _dirs, names in os.walk(path):
            for n in names:
                if _SCENE_RE.search(n) or _REQUEST_RE.search(n):
                    full = os.path.join(dirpath, n)
                    with open(full, encoding="utf-8") as fh:
                        files[os.path.relpath(full, path)] = fh.read()
        return files, root_name
    if not path.endswith((".tar.bz2", ".tbz2", ".tar.gz", ".tgz", ".tar")):
        raise CompassInputError(f"{path}: not a directory or .tar.bz2 archive of MotionBenchMaker problems")
    root_name = re.sub(r"\.(tar\.bz2|tbz2|tar\.gz|tgz|tar)$", "", root_name)
    try:
        with tarfile.open(path, "r:*") as tar:
            for member in tar.getmembers():
                base = os.path.basename(member.name)
                if member.isfile() and (_SCENE_RE.search(base) or _REQUEST_RE.search(base)):
                    fh = tar.extractfile(member)
                    files[os.path.normpath(member.name)] = fh.read().decode("utf-8")
    except (tarfile.TarError, OSError, EOFError, UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise CompassInputError(f"{path}: not a readable .tar.bz2 archive ({first.rstrip(':')})") from exc
    return files, root_name


def load_problems(path: str) -> list[MbmProblem]:
    """All problems under a directory or .tar.bz2 archive, sorted by family then number."""
    files, root_name = _read_files(str(path))
    scenes, requests = {}, {}
    for rel, text in files.items():
        folder, base = os.path.split(rel)
        m = _SCENE_RE.search(base)
        (scenes if m else requests)[(folder, (m or _REQUEST_RE.search(base)).group(1))] = (rel, text)
    if not scenes:
        raise CompassInputError(f"{path}: no sceneNNNN.yaml + requestNNNN.yaml pairs found")
    problems = []
    for key in sorted(scenes, key=lambda k: (_family_name(k[0], root_name), int(k[1]))):
        if key not in requests:
            raise CompassInputError(f"{path}: {scenes[key][0]} has no matching request{key[1]}.yaml")
        s_rel, s_text = scenes[key]
        r_rel, r_text = requests[key]
        boxes, cylinders, spheres, ids = parse_scene(_yaml_load(s_text, s_rel), s_rel)
        request = _yaml_load(r_text, r_rel)
        q_start, q_goals = parse_request(request, r_rel)
        problems.append(MbmProblem(_family_name(key[0], root_name), key[1], boxes, cylinders, spheres,
                                   q_start, q_goals, ids, parse_finger_width(request, r_rel)))
    return problems


