"""grasp/ is on the method side: it imports task, types, errors, geometry, robot, mapping and
motion only, never sim, trial, bench, viz or cli."""
import ast
import pathlib

import compass_manip.grasp as grasp_pkg

ALLOWED = {"task", "types", "errors", "geometry", "robot", "mapping", "motion", "grasp"}


def _imports(path: pathlib.Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1:  # from .x import y: inside grasp
                yield "grasp"
            elif node.level >= 2:
                yield (node.module or "").split(".")[0] or "<package root>"
            elif node.module and node.module.startswith("compass_manip"):
                parts = node.module.split(".")
                yield parts[1] if len(parts) > 1 else "<package root>"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("compass_manip"):
                    parts = alias.name.split(".")
                    yield parts[1] if len(parts) > 1 else "<package root>"


def test_grasp_imports_only_the_method_side():
    folder = pathlib.Path(grasp_pkg.__file__).parent
    files = sorted(folder.glob("*.py"))
    assert len(files) >= 5
    bad = {(f.name, m) for f in files for m in _imports(f) if m not in ALLOWED}
    assert not bad, f"grasp/ imports outside the method side: {sorted(bad)}"


def test_the_checker_sees_a_forbidden_import(tmp_path):
    f = tmp_path / "x.py"
    f.write_text("from ..sim.world import World\nimport compass_manip.trial.machine\n")
    assert set(_imports(f)) == {"sim", "trial"}
