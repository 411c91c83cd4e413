"""Method 3 (solvers/ode.py) against the exact method on the reference runs, within the error
bound of its tolerance (docs/explanation/accuracy.md, "Method 3's energy error" and "Machine
independence").

scipy's integrators call BLAS (``np.dot`` in each Runge-Kutta stage), whose kernel differs by CPU,
so method 3's last bits are the machine's: its runs are never pinned by digest. What holds on
every machine is its error bound: each accepted step keeps every state's local error within
NORM_FACTOR (atol + rtol |y|) (the step control's RMS norm over at most 5 components), so after
N steps a position is within N times that of the exact motion, the gap within twice it, and an
impact moves by at most that gap error over the closing speed (each earlier impact map at most
doubling the error: its coefficients are below 2 for e <= 1).
"""

from __future__ import annotations

import pytest

import reference_digests
from iceimpact import Scene
from iceimpact.solvers.ode import ATOL_SCALE, ODE_METHODS
from random_search import NORM_FACTOR, STAGES


@pytest.mark.parametrize("case", reference_digests.METHOD_3_CASES, ids=lambda c: c[0])
def test_method_3_finds_the_exact_impacts_within_its_error_bound(case):
    _, _, changes, t_end, h, flow = case
    ode, reports = reference_digests.stepped(Scene(**changes), "step", t_end, h, flow)
    exact, _ = reference_digests.stepped(Scene(**{**changes, "solver_method": 1}), "step", t_end,
                                         h, flow)
    largest = max(max(abs(r.x), abs(r.z)) for r in reports)
    scene = ode.scene
    rtol = scene.solver_rtol
    # over-counts the steps for an implicit integrator (1 evaluation a step)
    steps = ode.solver.nfev / STAGES.get(ODE_METHODS[scene.solver_ode_method], 1)
    gap_error = 2.0 * NORM_FACTOR * steps * (ATOL_SCALE * rtol + rtol * largest)
    assert exact.impacts, "a reference run with no impact compares nothing"
    assert len(ode.impacts) == len(exact.impacts)
    for k, (found, truth) in enumerate(zip(ode.impacts, exact.impacts, strict=True)):
        closing = truth.w_minus - truth.v_minus
        assert closing > 0.0
        bound = 2.0 ** k * gap_error / closing
        assert abs(found.t - truth.t) <= bound, (k, found.t, truth.t, bound)
