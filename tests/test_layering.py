"""The boundary, enforced: method packages never import the simulator or the harness.

robot, mapping, motion, exploration, perception and grasp see a Task and Observations
only; sim (ground truth), trial, bench, viz and cli sit on the other side. Checked on the
source with `ast`, so an import inside a function counts too.
"""
import ast
import pathlib

import pytest

PKG = pathlib.Path(__file__).resolve().parents[1] / "src" / "compass_manip"
METHOD_SIDE = ("robot", "mapping", "motion", "exploration", "perception", "grasp")
FORBIDDEN = ("sim", "trial", "bench", "viz", "cli")
#: Top-level modules a method package may import besides its own layer's peers.
SHARED = ("task", "types", "errors", "geometry")


def imported_packages(path: pathlib.Path) -> list[tuple[int, str]]:
    """(line, first package below compass_manip) of every import of a compass_manip module."""
    rel_parts = path.relative_to(PKG).parts[:-1]  # the module's package inside compass_manip
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "compass_manip" and len(parts) > 1:
                    out.append((node.lineno, parts[1]))
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                parts = (node.module or "").split(".")
                if parts[0] != "compass_manip":
                    continue
                target = parts[1:]
            else:
                base = list(rel_parts)[: len(rel_parts) - (node.level - 1)] if node.level > 1 else list(rel_parts)
                target = base + (node.module.split(".") if node.module else [])
            if target:
                out.append((node.lineno, target[0]))
            else:  # `from .. import x`: x names the package
                out.extend((node.lineno, a.name) for a in node.names)
    return out


def method_side_files():
    for pkg in METHOD_SIDE:
        folder = PKG / pkg
        if folder.is_dir():
            yield from sorted(folder.rglob("*.py"))


def test_the_method_side_exists():
    files = list(method_side_files())
    assert {f.relative_to(PKG).parts[0] for f in files} >= {"robot", "mapping", "motion", "exploration"}


@pytest.mark.parametrize("path", list(method_side_files()), ids=lambda p: str(p.relative_to(PKG)))
def test_method_side_never_imports_the_simulator_or_the_harness(path):
    bad = [f"{path.relative_to(PKG)}:{line} imports compass_manip.{pkg}"
           for line, pkg in imported_packages(path) if pkg in FORBIDDEN]
    assert not bad, "; ".join(bad)


@pytest.mark.parametrize("path", list(method_side_files()), ids=lambda p: str(p.relative_to(PKG)))
def test_method_side_imports_only_the_method_side_and_shared_modules(path):
    allowed = set(METHOD_SIDE) | set(SHARED)
    bad = [f"{path.relative_to(PKG)}:{line} imports compass_manip.{pkg}"
           for line, pkg in imported_packages(path) if pkg not in allowed]
    assert not bad, "; ".join(bad)


def test_the_checker_sees_relative_and_absolute_imports(tmp_path):
    probe = PKG / "exploration" / "_layering_probe.py"
    assert not probe.exists()
    probe.write_text("from ..sim import world\nimport compass_manip.trial.runner\nfrom .. import bench\n"
                     "def f():\n    from ..viz.images import save_rgb_png\n")
    try:
        found = {pkg for _, pkg in imported_packages(probe)}
    finally:
        probe.unlink()
    assert found == {"sim", "trial", "bench", "viz"}
