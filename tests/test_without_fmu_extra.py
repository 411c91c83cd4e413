"""The tests of the core need none of the FMU extra: with FMPy unimportable, the tests of the
physics, the solvers, the scene and the simulator collect, and the physics tests pass; the FMU
tests, which need FMPy, fail to import (the blocker works)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: A pytest plugin, loaded before any conftest: any import of fmpy then raises ImportError.
BLOCKER = 'import sys\nsys.modules["fmpy"] = None\n'
#: The tests of the core: none may import FMPy when it is collected.
CORE = ["tests/physics", "tests/solvers", "tests/test_scene.py", "tests/test_simulator.py",
        "tests/test_limits.py", "tests/test_state.py", "tests/test_reference_digests.py"]


def _pytest_without_fmpy(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    (tmp_path / "block_fmpy.py").write_text(BLOCKER)
    paths = [str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "block_fmpy",
                           "-p", "no:cacheprovider", "-q", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)


def test_core_tests_collect_and_physics_tests_pass_without_fmpy(tmp_path):
    collected = _pytest_without_fmpy(tmp_path, "--co", *CORE)
    assert collected.returncode == 0, collected.stdout[-4000:] + collected.stderr[-2000:]
    assert "error" not in collected.stdout.splitlines()[-1]
    ran = _pytest_without_fmpy(tmp_path, "-m", "not slow", "tests/physics")
    assert ran.returncode == 0, ran.stdout[-4000:] + ran.stderr[-2000:]
    assert " passed" in ran.stdout.splitlines()[-1]


def test_the_blocker_stops_fmpy(tmp_path):
    done = _pytest_without_fmpy(tmp_path, "--co", "tests/fmu/test_fmu.py")
    assert done.returncode != 0
    assert "import of fmpy halted" in done.stdout
