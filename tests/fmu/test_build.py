"""The FMU build (fmu_build/): it refuses a PythonFMU with no FMI binaries rather than make an
FMU without them."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from native_host import ROOT

pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")

#: a fresh process that runs the FMU in itself (FMPy, PythonFMU's library in process) before it
#: builds one, and prints the build's refusal
_BUILD_AFTER_A_RUN = """
import sys
from fmpy import simulate_fmu
simulate_fmu(sys.argv[1], stop_time=0.01)
sys.path.insert(0, sys.argv[2])
from fmu_build import fmi2
try:
    fmi2.build(sys.argv[3])
except RuntimeError as exc:
    print("refused:", exc)
else:
    print("built")
"""


def test_a_build_after_an_fmu_ran_in_the_process_is_refused_with_the_reason(fmu, tmp_path):
    """PythonFMU puts the FMU's resources/ (a slim pythonfmu: no binaries) first on sys.path of
    the process that ran it; a build there would import that copy and make an FMU without
    binaries/. It is refused, naming the folder and what to do."""
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(_BUILD_AFTER_A_RUN), str(fmu),
                          str(ROOT), str(tmp_path / "dist")], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "refused: pythonfmu was imported from" in out.stdout, out.stdout[-2000:]
    assert "resources" in out.stdout and "fresh process" in out.stdout
    assert not (tmp_path / "dist" / "IceImpact.fmu").exists()
