import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")

#: The repository root and the data shipped with it (data/README.md).
REPO_ROOT = Path(__file__).resolve().parents[1]
MBM_ARCHIVE = REPO_ROOT / "data" / "mbm-panda.tar.bz2"

# Property-based suites (tests/test_inputs_*.py): a few examples per property in `make test`,
# many under COMPASS_HYPOTHESIS=slow (or `pytest -m slow`, which selects the slow profile).
try:
    from hypothesis import HealthCheck, settings

    _common = dict(deadline=None, derandomize=True, print_blob=True,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    settings.register_profile("ci", max_examples=12, **_common)
    settings.register_profile("slow", max_examples=300, **_common)
    settings.load_profile(os.environ.get("COMPASS_HYPOTHESIS", "ci"))
except ImportError:  # pragma: no cover - hypothesis is in the [test] extra
    pass


def _slow_run(config) -> bool:
    return (config.getoption("markexpr", default="") or "").strip() == "slow"


def pytest_configure(config):
    """`pytest -m slow`: the property suites run too, with the slow profile's examples."""
    if _slow_run(config) and "COMPASS_HYPOTHESIS" not in os.environ:
        try:
            from hypothesis import settings

            settings.load_profile("slow")
        except ImportError:  # pragma: no cover
            pass


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    if _slow_run(config):  # select the property suites under -m slow as well
        for item in items:
            if item.path.name.startswith("test_inputs_"):
                item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def mbm_archive() -> str:
    """Path of the MotionBenchMaker archive shipped in data/; a missing file fails the test."""
    assert MBM_ARCHIVE.is_file(), f"{MBM_ARCHIVE} is missing: it ships with the repository (data/README.md)"
    return str(MBM_ARCHIVE)
