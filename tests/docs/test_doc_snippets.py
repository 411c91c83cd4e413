"""Snippets of the docs run as written and do what the page says: the time-varying flow of
docs/getting-started/fmpy.md without FMPy's "missing input" warnings, the by-hand FMU3Slave loop
of docs/how-to/use-early-return.md (its early returns are the impacts), and
examples/system/system.py prints its table only (libcosim's debug log silenced). About 15 s."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


def python_block(page: Path, after: str, index: int = 0) -> str:
    """The ``index``-th Python block of ``page`` after the text ``after``."""
    text = page.read_text().split(after, 1)[1]
    return text.split("```python\n")[index + 1].split("```", 1)[0]


def test_the_flow_input_runs_without_warnings(fmu: Path, capfd) -> None:
    code = python_block(DOCS / "getting-started" / "fmpy.md", "A time-varying flow")
    assert code.count('"dist/IceImpact.fmu"') == 1
    namespace: dict = {}
    exec(compile(code.replace('"dist/IceImpact.fmu"', repr(str(fmu))), "fmpy.md", "exec"),
         namespace)
    out, err = capfd.readouterr()
    assert "Warning" not in out + err and "missing input" not in out + err, out + err
    result = namespace["result"]
    assert result["time"][-1] == 200.0 and result["contact.count"][-1] > 0


def test_the_fmu3slave_loop_by_hand(fmu3: Path) -> None:
    code = python_block(DOCS / "how-to" / "use-early-return.md", "By hand")
    assert code.count('"dist/IceImpact3.fmu"') == 1
    namespace: dict = {}
    exec(compile(code.replace('"dist/IceImpact3.fmu"', repr(str(fmu3))), "use-early-return.md",
                 "exec"), namespace)
    impacts, count = namespace["impacts"], namespace["count"]
    # the default scene: every early return over 20 s is an impact (no sticking yet)
    assert count > 0 and len(impacts) == count
    assert np.all(np.diff(impacts) > 0) and 0.0 < impacts[0] < impacts[-1] < 20.0
    assert np.isfinite(namespace["x"])


def test_the_system_example_is_quiet(fmus: Path) -> None:
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "system" / "system.py"),
                           "--fmus", str(fmus)], capture_output=True, text=True, cwd=ROOT,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = (done.stdout + done.stderr).splitlines()
    assert len(lines) <= 16, "\n".join(lines)
    assert not any("debug" in line.lower() for line in lines), "\n".join(lines)
