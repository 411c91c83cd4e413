"""Every number of the reference runs (tests/reference_digests.py) is the stored one, to the bit:
with the compiled flight search where numba is installed, and with the pure one.

Restructuring moves and rewrites code without changing behaviour, so the digests stay; a change
of behaviour that is meant regenerates them, with its reason in CHANGELOG.md. They hold on every
machine (tests/test_machine_matrix.py runs them under several BLAS kernels and SIMD levels).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

import reference_digests
from fmu_host import ROOT

#: every number, or on a CPU without FMA (the C library's SSE2 variants) the events
COMPARED = (dict if reference_digests.libm_has_fma_variants()
            else reference_digests.event_quantities)


@pytest.mark.parametrize("case", [c[0] for c in reference_digests.CASES])
def test_the_reference_run_reports_the_stored_numbers(case):
    assert (COMPARED(reference_digests.compute([case])[case])
            == COMPARED(reference_digests.stored()[case]))


def test_the_pure_flight_search_reports_the_stored_numbers_too(tmp_path):
    out = tmp_path / "pure.json"
    done = subprocess.run([sys.executable, str(ROOT / "tests" / "reference_digests.py"), str(out)],
                          env={**os.environ, "ICEIMPACT_PURE": "1"}, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    pure, stored = json.loads(out.read_text()), reference_digests.stored()
    assert {case: COMPARED(d) for case, d in pure.items()} == \
        {case: COMPARED(d) for case, d in stored.items()}


def test_every_case_is_stored():
    assert set(reference_digests.stored()) == {c[0] for c in reference_digests.CASES}
