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
import zlib
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
    except (yaml.YAMLError, ValueError, TypeError, RecursionError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise CompassInputError(f"{where} is not valid YAML: {first}") from exc


def _mapping(value, where: str, optional: bool = False) -> dict:
    """value if it is a mapping ({} for a missing optional one), else CompassInputError."""
    if value is None and optional:
        return {}
    if not isinstance(value, dict):
        raise CompassInputError(f"{where} must be a mapping, got {type(value).__name__} {value!r:.60}")
    return value


def _list(value, where: str, optional: bool = True) -> list:
    """value if it is a list ([] for a missing optional one), else CompassInputError."""
    if value is None and optional:
        return []
    if not isinstance(value, list):
        raise CompassInputError(f"{where} must be a list, got {type(value).__name__} {value!r:.60}")
    return value


def _number(value, where: str, unit: str) -> float:
    """A finite YAML number (int or float, not bool or string) as float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise CompassInputError(f"{where} = {value!r:.60} is not allowed; use a finite number [{unit}]")
    return float(value)


def _vec(value, keys: str, where: str) -> np.ndarray:
    """A position or quaternion given as a list or as a mapping {x:, y:, z:(, w:)}."""
    if isinstance(value, dict):
        missing = [k for k in keys if k not in value]
        if missing:
            raise CompassInputError(f"{where}: keys {missing} missing; expected {', '.join(keys)}")
        value = [value[k] for k in keys]
    if not isinstance(value, list) or len(value) != len(keys):
        raise CompassInputError(f"{where}: expected {len(keys)} finite numbers ({keys}), got {value!r:.80}")
    return np.array([_number(v, f"{where}.{k}", "m" if keys == "xyz" else "-") for v, k in zip(value, keys)])


def _pose(pose, where: str) -> np.ndarray:
    pose = _mapping(pose, where, optional=True)
    if not pose:
        return np.eye(4)
    xyzw = _vec(pose.get("orientation", [0, 0, 0, 1]), "xyzw", f"{where}.orientation")
    n = np.linalg.norm(xyzw)
    if not 0.5 < n < 2.0:
        raise CompassInputError(f"{where}.orientation {xyzw.tolist()} is not a unit quaternion (norm {n:.3g}); "
                                "use x, y, z, w with norm 1")
    x, y, z, w = xyzw / n
    return make_T(quat_to_R([w, x, y, z]), _vec(pose.get("position", [0, 0, 0]), "xyz", f"{where}.position"))


#: Largest joint value [rad] read as such (the Panda's limits are within +-2.9 rad); larger
#: values are taken for degrees and refused.
MAX_JOINT_ABS = 2.0 * np.pi
#: Largest primitive size [m] read as such; larger values are taken for millimetres.
MAX_SIZE = 50.0

#: Largest scene or request file read [bytes] (the shipped ones are below 10 kB): bounds the
#: memory a folder or a (possibly compressed-bomb) archive can take.
MAX_FILE_BYTES = 16 << 20

#: Number of dimensions [m] of each MoveIt primitive type (`shape_msgs/SolidPrimitive`).
_DIMS = {"box": 3, "cylinder": 2, "sphere": 1}
_TYPE_CODES = {"1": "box", "2": "sphere", "3": "cylinder"}


def parse_scene(data, where: str) -> tuple[tuple, tuple, tuple, tuple]:
    """(boxes, cylinders, spheres, obstacle ids) of a MoveIt planning scene mapping; see
    MbmProblem. A scene must have a `world` key (MoveIt writes it last, so a file cut off
    early has none); every object must have primitives, with positive finite dimensions."""
    if not isinstance(data, dict):
        raise CompassInputError(f"{where} is not a MoveIt planning scene (no mapping at top level)")
    if "world" not in data:
        raise CompassInputError(f"{where} has no 'world' key: not a MoveIt planning scene, or the file is cut off")
    if data["world"] is None:
        raise CompassInputError(f"{where}: 'world' is empty (file cut off?); a scene lists its collision_objects")
    world = _mapping(data["world"], f"{where}: world")
    if "collision_objects" in world and world["collision_objects"] is None:
        raise CompassInputError(f"{where}: world.collision_objects is empty (file cut off?); give a list, [] for none")
    objects = _list(world.get("collision_objects"), f"{where}: world.collision_objects")
    boxes, cylinders, spheres = [], [], []
    ids: dict[str, list] = {"box": [], "cylinder": [], "sphere": []}
    for k, obj in enumerate(objects):
        obj = _mapping(obj, f"{where}: world.collision_objects[{k}]")
        oid = str(obj.get("id", f"#{k}"))
        at = f"{where}: object {oid!r}"
        if obj.get("operation") in (1, 2, "remove", "REMOVE"):
            continue
        if obj.get("meshes") or obj.get("planes"):
            raise CompassInputError(f"{at} has meshes or planes; only box, cylinder, sphere are supported")
        T_world_obj = _pose(obj.get("pose"), f"{at} pose")
        prims = _list(obj.get("primitives"), f"{at} primitives")
        poses = _list(obj.get("primitive_poses"), f"{at} primitive_poses")
        if not prims:
            raise CompassInputError(f"{at} has no primitives (file cut off?); give box, cylinder or sphere primitives")
        if len(prims) != len(poses):
            raise CompassInputError(f"{at} has {len(prims)} primitives but {len(poses)} primitive_poses")
        for i, (prim, pose) in enumerate(zip(prims, poses)):
            prim = _mapping(prim, f"{at} primitives[{i}]")
            T = T_world_obj @ _pose(pose, f"{at} primitive_poses[{i}]")
            kind = str(prim.get("type", "")).lower()
            kind = _TYPE_CODES.get(kind, kind)
            if kind not in _DIMS:
                raise CompassInputError(f"{at}: primitive type {kind!r} is not supported; use box, cylinder or sphere")
            raw = _list(prim.get("dimensions"), f"{at} primitives[{i}].dimensions", optional=False)
            dims = np.array([_number(v, f"{at} primitives[{i}].dimensions[{j}]", "m") for j, v in enumerate(raw)])
            if np.any(dims > MAX_SIZE):
                raise CompassInputError(f"{at}: {kind} dimensions {dims.tolist()} exceed {MAX_SIZE} m; MoveIt "
                                        "sizes are metres (millimetres?)")
            if dims.shape != (_DIMS[kind],) or not np.all(dims > 0):
                what = {"box": "3 sizes x, y, z", "cylinder": "[height, radius]", "sphere": "[radius]"}[kind]
                raise CompassInputError(f"{at}: {kind} dimensions {dims.tolist()} are not allowed; a {kind} needs "
                                        f"{what} > 0 [m]")
            if kind == "box":
                boxes.append((T, 0.5 * dims))
            elif kind == "cylinder":
                cylinders.append((T, float(dims[1]), 0.5 * float(dims[0])))
            else:
                spheres.append((T[:3, 3].copy(), float(dims[0])))
            ids[kind].append(oid)
    return tuple(boxes), tuple(cylinders), tuple(spheres), tuple(ids["box"] + ids["cylinder"] + ids["sphere"])


def _start_joints(data: dict, where: str) -> dict:
    """{joint name: position} of a request's start state; names and positions checked."""
    start_state = _mapping(data.get("start_state"), f"{where}: start_state")
    js = _mapping(start_state.get("joint_state"), f"{where}: start_state.joint_state")
    names = _list(js.get("name"), f"{where}: start_state.joint_state.name", optional=False)
    pos = _list(js.get("position"), f"{where}: start_state.joint_state.position", optional=False)
    if len(names) != len(pos):
        raise CompassInputError(f"{where}: start_state.joint_state has {len(names)} names but {len(pos)} positions")
    return {str(n): (v, f"{where}: start_state.joint_state.position[{i}] ({n})") for i, (n, v) in enumerate(zip(names, pos))}


def parse_request(data, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(q_start (7,), q_goals (k,7)) [rad] of a MoveIt motion plan request mapping. Joint
    values must be finite numbers (NaN or inf raise; finite values outside the limits are
    kept and reported by the solver as outside_limits)."""
    if not isinstance(data, dict):
        raise CompassInputError(f"{where} is not a MoveIt motion plan request (no mapping at top level)")
    start = _start_joints(data, where)
    missing = [j for j in ARM_JOINTS if j not in start]
    if missing:
        raise CompassInputError(f"{where}: start state lacks joints {missing}")
    q_start = np.array([_number(*start[j], "rad") for j in ARM_JOINTS])
    goals = []
    for g, gc in enumerate(_list(data.get("goal_constraints"), f"{where}: goal_constraints")):
        gc = _mapping(gc, f"{where}: goal_constraints[{g}]")
        jc = {}
        for c, con in enumerate(_list(gc.get("joint_constraints"), f"{where}: goal_constraints[{g}].joint_constraints")):
            con = _mapping(con, f"{where}: goal_constraints[{g}].joint_constraints[{c}]")
            name = con.get("joint_name")
            if not isinstance(name, str):
                raise CompassInputError(f"{where}: goal_constraints[{g}].joint_constraints[{c}].joint_name "
                                        f"{name!r:.40} is not allowed; use a joint name")
            jc[name] = (con.get("position"), f"{where}: goal_constraints[{g}].joint_constraints[{c}] ({name}) position")
        if all(j in jc for j in ARM_JOINTS):
            goals.append([_number(*jc[j], "rad") for j in ARM_JOINTS])
    if not goals:
        raise CompassInputError(f"{where}: no joint-space goal constraint covering {ARM_JOINTS[0]}..{ARM_JOINTS[-1]}")
    q_goals = np.asarray(goals, dtype=np.float64).reshape(-1, N_ARM_JOINTS)
    for what, q in (("start state", q_start[None]), ("goal", q_goals)):
        if np.any(np.abs(q) > MAX_JOINT_ABS):
            raise CompassInputError(f"{where}: {what} joint value {q[np.abs(q) > MAX_JOINT_ABS][0]} exceeds "
                                    f"{MAX_JOINT_ABS:.3f} rad (2 pi); MoveIt joint positions are radians (degrees?)")
    return q_start, q_goals


def parse_finger_width(data, where: str) -> float:
    """Finger opening [m] of a request's start state: the sum of its two finger joints
    (`*finger_joint1`, `*finger_joint2`); GRIPPER_MAX_WIDTH when it names no finger joint."""
    start = _start_joints(_mapping(data, where), where)
    fingers = [_number(v, at, "m") for k in ("finger_joint1", "finger_joint2")
               for n, (v, at) in start.items() if n.endswith(k)]
    if not fingers:
        return GRIPPER_MAX_WIDTH
    width = float(sum(fingers)) * (2.0 / len(fingers))
    if not (np.isfinite(width) and 0.0 <= width <= MAX_FINGER_WIDTH):
        raise CompassInputError(f"{where}: finger opening {width} m (sum of the finger joints) is not allowed; "
                                f"use 0..{MAX_FINGER_WIDTH} m")
    return width


def _family_name(folder: str, root_name: str) -> str:
    name = os.path.basename(folder.rstrip("/")) or root_name
    return name[: -len("_panda")] if name.endswith("_panda") else name


def _decode(raw: bytes, where: str) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise CompassInputError(f"{where} is not UTF-8 text (byte {exc.start}); MotionBenchMaker YAML files are "
                                "UTF-8") from exc


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
                    if os.path.getsize(full) > MAX_FILE_BYTES:
                        raise CompassInputError(f"{full}: {os.path.getsize(full)} bytes is too large for a "
                                                f"MotionBenchMaker YAML file (at most {MAX_FILE_BYTES})")
                    try:
                        with open(full, "rb") as fh:
                            files[os.path.relpath(full, path)] = _decode(fh.read(), full)
                    except OSError as exc:
                        raise CompassInputError(f"{full}: cannot be read ({exc.strerror or exc})") from exc
        return files, root_name
    if not path.endswith((".tar.bz2", ".tbz2", ".tar.gz", ".tgz", ".tar")):
        raise CompassInputError(f"{path}: not a directory or .tar.bz2 archive of MotionBenchMaker problems")
    root_name = re.sub(r"\.(tar\.bz2|tbz2|tar\.gz|tgz|tar)$", "", root_name)
    try:
        with tarfile.open(path, "r:*") as tar:
            for member in tar.getmembers():
                base = os.path.basename(member.name)
                if member.isfile() and (_SCENE_RE.search(base) or _REQUEST_RE.search(base)):
                    if member.size > MAX_FILE_BYTES:
                        raise CompassInputError(f"{path}: {member.name} holds {member.size} bytes, too large for a "
                                                f"MotionBenchMaker YAML file (at most {MAX_FILE_BYTES})")
                    fh = tar.extractfile(member)
                    files[os.path.normpath(member.name)] = _decode(fh.read(), f"{path}: {member.name}")
    except CompassInputError:
        raise
    except (tarfile.TarError, OSError, EOFError, ValueError, zlib.error) as exc:
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


