"""exploration/ and perception/ import only task, types, errors, geometry, robot, mapping,
motion (and each other's own package, the standard library and third-party packages)."""
import ast
import pathlib

import compass_manip

ROOT = pathlib.Path(compass_manip.__file__).parent
ALLOWED = {"task", "types", "errors", "geometry", "robot", "mapping", "motion"}
CHECKED = ("exploration", "perception")


def _imported_subpackages(path: pathlib.Path, package: str):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 0 and node.module and node.module.startswith("compass_manip."):
                yield node.module.split(".")[1], node.lineno
            elif node.level == 1:
                yield package, node.lineno
            elif node.level >= 2:
                mod = (node.module or "").split(".")[0]
                yield (mod or next(iter(a.name for a in node.names))), node.lineno
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("compass_manip."):
                    yield a.name.split(".")[1], node.lineno


def test_methods_and_perception_never_import_sim_trial_bench_viz_cli():
    bad = []
    for package in CHECKED:
        files = sorted((ROOT / package).glob("*.py"))
        assert files, package
        for f in files:
            for sub, line in _imported_subpackages(f, package):
                if sub not in ALLOWED and sub not in CHECKED:
                    bad.append(f"{package}/{f.name}:{line} imports {sub}")
    assert not bad, bad


def test_the_check_sees_a_forbidden_import(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("from ..sim.world import World\nfrom ..mapping import occupancy\n")
    assert [s for s, _ in _imported_subpackages(f, "exploration")] == ["sim", "mapping"]
