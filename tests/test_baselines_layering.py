"""The oracle reference lives on the trial side: no method package can import it, it is
not a registered method, and only the trial runner wires it (extends the layering check)."""
import ast
import pathlib

import compass_manip
from compass_manip.exploration.registry import available_methods
from compass_manip.trial.oracle_method import ORACLE_METHOD

from test_layering import FORBIDDEN, imported_packages, method_side_files

ROOT = pathlib.Path(compass_manip.__file__).parent


def _imports_oracle(path: pathlib.Path) -> bool:
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.endswith("oracle_method"):
            return True
        if isinstance(node, ast.ImportFrom) and any(a.name == "oracle_method" for a in node.names):
            return True
        if isinstance(node, ast.Import) and any(a.name.endswith("oracle_method") for a in node.names):
            return True
    return False


def test_only_the_trial_runner_imports_the_oracle():
    users = sorted(str(f.relative_to(ROOT)) for f in ROOT.rglob("*.py") if _imports_oracle(f))
    assert users == ["trial/runner.py"], users


def test_method_packages_cannot_reach_the_oracle_package():
    # the oracle's package (trial) is outside what method packages may import
    assert "trial" in FORBIDDEN
    for f in method_side_files():
        assert "trial" not in {pkg for _, pkg in imported_packages(f)}, f


def test_the_oracle_check_sees_an_oracle_import(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("from ..trial.oracle_method import OracleMethod\n")
    assert _imports_oracle(f)


def test_the_oracle_is_not_a_registered_method():
    assert ORACLE_METHOD not in available_methods()
    assert {"fv", "ig", "ig-occlusion", "gse"} <= set(available_methods())
