"""fmuCheck, the FMI standard's compliance checker (../shared/tools/fmucheck, FMI 1.0 and 2.0), on
IceImpact.fmu as built, documentation/index.html inside: the checker reports no error or warning,
the FMU reports none to it, and the run it makes is FMPy's run of the same steps.

fmuCheck's exit status is non-zero only for a fatal error, so the summary it writes to its log is
read instead."""

from __future__ import annotations

import csv
import re
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

from native_host import FMUCHECK, FMUCHECK_ABSENT

#: The run: 2 s of co-simulation at 1 ms steps, every step written (about 3 s).
STOP, STEP = 2.0, 0.001
#: The summary at the end of fmuCheck's log.
SUMMARY = re.compile(r"FMU reported:\s+(\d+) warning\(s\) and error\(s\)\s+"
                     r"Checker reported:\s+(\d+) Warning\(s\)\s+(\d+) Error\(s\)")


def summary(log: str) -> dict[str, int]:
    """The counts of fmuCheck's summary: what the FMU reported, the checker's warnings and
    errors. A log without the summary is an error here, never a pass."""
    found = SUMMARY.search(log)
    assert found, f"no summary in fmuCheck's log:\n{log[-2000:]}"
    fmu, warnings, errors = (int(n) for n in found.groups())
    return {"fmu": fmu, "warnings": warnings, "errors": errors}


def test_the_summary_is_read_as_written() -> None:
    """The reader above on a log with findings (so the test below can fail)."""
    log = ("FMU check summary:\nFMU reported:\n\t2 warning(s) and error(s)\nChecker reported:\n"
           "\t1 Warning(s)\n\t3 Error(s)\n")
    assert summary(log) == {"fmu": 2, "warnings": 1, "errors": 3}
    with pytest.raises(AssertionError, match="no summary"):
        summary("fmuCheck: fatal error\n")


def _csv(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    data = np.array([[float(v) for v in row] for row in rows[1:]])
    return {name.strip('"'): data[:, i] for i, name in enumerate(rows[0])}


@pytest.mark.skipif(FMUCHECK is None, reason=FMUCHECK_ABSENT)
def test_fmucheck_finds_nothing_and_runs_as_fmpy(fmu: Path, tmp_path: Path) -> None:
    with zipfile.ZipFile(fmu) as zf:
        assert "documentation/index.html" in zf.namelist()
    log, out = tmp_path / "log.txt", tmp_path / "out.csv"
    done = subprocess.run([str(FMUCHECK), "-k", "cs", "-h", str(STEP), "-s", str(STOP),
                           "-n", "0", "-l", "3", "-t", str(tmp_path), "-o", str(out),
                           "-e", str(log), str(fmu)],
                          capture_output=True, text=True, timeout=120)
    text = log.read_text() if log.exists() else ""
    assert done.returncode == 0, done.stdout + done.stderr + text
    assert summary(text) == {"fmu": 0, "warnings": 0, "errors": 0}, text
    checked = _csv(out)
    fmpy = simulate_fmu(str(fmu), stop_time=STOP, output_interval=STEP)
    assert len(checked["time"]) == len(fmpy) == round(STOP / STEP) + 1
    assert checked["contact.count"][-1] == fmpy["contact.count"][-1] > 0
    assert np.array_equal(checked["contact.count"], fmpy["contact.count"])
    assert np.array_equal(checked["contact.t_last"], fmpy["contact.t_last"])
    # (fmuCheck sums its steps, FMPy multiplies: the step ends differ in the last bits)
    for name in ("structure.x", "structure.v", "ice.z", "ice.v"):
        scale = np.max(np.abs(fmpy[name]))
        np.testing.assert_allclose(checked[name], fmpy[name], rtol=0, atol=1e-9 * scale,
                                   err_msg=name)
