import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

# `retalisc run` keeps compiled programs in a cache directory (retalisc/compile_cache.py): the
# tests (and the commands they start) use one of their own, not the user's.
_CACHE = tempfile.TemporaryDirectory(prefix="retalisc-test-cache-")
os.environ["RETALISC_CACHE_DIR"] = _CACHE.name


def pytest_addoption(parser):
    parser.addoption("--update-golden", action="store_true",
                     help="Rewrite every expectation of the golden cases, tests/golden_cases.py (review the diff!)")


@pytest.fixture
def update_golden(request):
    return request.config.getoption("--update-golden")


@pytest.fixture(scope="session")
def swipl():
    path = shutil.which("swipl")
    if path is None:
        pytest.fail("swipl is not installed (apt-get install swi-prolog-nox)")
    return path


@pytest.fixture(scope="session")
def retalisc_cmd():
    """The retalisc command line, run with the interpreter running the tests."""
    return [sys.executable, "-m", "retalisc"]
