"""The riding phase's Taylor steps on the modes (solvers/search/modal_taylor.py): the compiled
kernels are the Python functions to the bit, whatever room their arrays start with, and a
riding phase's steps and samples are the same whichever way they are asked for."""

from __future__ import annotations

import bisect

import numpy as np
import pytest

from iceimpact import Scene
from iceimpact.simulator import Simulator
from iceimpact.solvers.exact.modal import ModalRide
from iceimpact.solvers.search import modal_taylor

TWO_MODES = dict(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                 structure_mode2_zeta=0.02, structure_mode2_phi=0.6)
#: riding scenes: the linear drag (it rides on), the quadratic drag with a flow that reverses
#: (the ice is pulled off: a separation)
SCENES = {"linear": dict(impact_e=0.0, flow_u=0.3, **TWO_MODES),
          "quadratic": dict(impact_e=0.0, drag_model=2, flow_u=0.2, **TWO_MODES)}


def _riding(fields: dict) -> ModalRide:
    """The first riding phase of the scene (its first steps not yet made)."""
    sim = Simulator(Scene(**fields))
    for _ in range(20000):
        sim.advance(1e-2)
        seg = sim.solver.seg
        if isinstance(seg, ModalRide):
            return ModalRide(sim.solver.context, seg.t0, seg.q0, seg.p0, seg.u, seg.start)
    raise AssertionError("the scene never rides")


def _steps(ride: ModalRide, kernel, capacity: int, target: float, check: int, u=None):
    """ride_steps run by ``kernel`` from the phase's anchor into arrays of ``capacity`` steps,
    grown (doubled) while full; the outcome and the arrays."""
    n = ride.modes.count
    rows = 2 * n + 2
    steps, ends = np.empty((capacity, 3)), np.empty((capacity, rows))
    tables = np.empty((capacity, rows, modal_taylor.ORDER + 1))
    counts = np.zeros(2, dtype=np.int64)
    loads = [a.copy() for a in ride._loads]
    while True:
        outcome = kernel(ride._q0, ride._p0, ride.t0, loads[0], loads[1], ride.modes.since,
                         ride._table, loads[2], ride.u if u is None else u, ride._alpha,
                         ride._beta, ride._coef, ride._quadratic, ride._rate,
                         np.empty(modal_taylor.ORDER + 1), loads[3], np.empty(n), np.empty(n),
                         steps, tables, ends, counts, target, ride.start, check)
        if outcome[0] != modal_taylor.FULL:
            count = int(counts[0])
            return outcome, steps[:count], tables[:count], ends[:count], counts
        grown = [np.empty((2 * len(a), *a.shape[1:])) for a in (steps, tables, ends)]
        for new, old in zip(grown, (steps, tables, ends), strict=True):
            new[:len(old)] = old
        steps, tables, ends = grown


def _same(a, b) -> None:
    assert a[0] == b[0]
    for x, y in zip(a[1:], b[1:], strict=True):
        assert np.asarray(x).tobytes() == np.asarray(y).tobytes()


@pytest.mark.parametrize("name", SCENES)
def test_the_steps_are_the_same_whatever_room_the_arrays_start_with(name):
    """Made into arrays that fill again and again (a step at a time) or at once: the same
    steps, tables and ends; made to a target, then searched for a separation, or searched at
    once: the same."""
    ride = _riding(SCENES[name])
    python = modal_taylor.ride_steps
    once = _steps(ride, python, 4096, 3.0, 0)
    assert once[0][0] == modal_taylor.REACHED and len(once[1]) > 16
    assert once[1][-1, modal_taylor.HI] >= 3.0 > once[1][-2, modal_taylor.HI]
    _same(_steps(ride, python, 1, 3.0, 0), once)
    checked = _steps(ride, python, 1, 3.0, 1)
    k = len(checked[1])
    for mine, theirs in zip(checked[1:4], once[1:4], strict=True):
        assert mine.tobytes() == theirs[:k].tobytes()
    if checked[0][0] == modal_taylor.SEPARATES:  # (the steps after the separation's dropped)
        assert checked[0][1] == k - 1 and 0.0 <= checked[0][2] <= 1.0
    else:
        assert checked[0][0] == modal_taylor.REACHED
        assert checked[4][modal_taylor.CHECKED] == k


@pytest.mark.skipif(modal_taylor.COMPILED is None, reason="numba absent or ICEIMPACT_PURE set")
@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("u", [None, -0.3])
def test_the_compiled_steps_and_rows_are_the_python_functions(name, u):
    """ride_steps and ride_rows_at compiled against the same functions run as Python: the same
    outcome, steps, tables and ends, and the same rows at 997 times (in steps, at their ends,
    before the first), riding on and (the flow reversed) separating."""
    ride = _riding(SCENES[name])
    compiled = modal_taylor.COMPILED
    for check in (0, 1):
        python = _steps(ride, modal_taylor.ride_steps, 8, 2.0, check, u)
        _same(_steps(ride, compiled["ride_steps"], 8, 2.0, check, u), python)
    if u is not None:
        assert python[0][0] == modal_taylor.SEPARATES
    steps, tables, ends = python[1], python[2], python[3]
    taus = np.concatenate((np.linspace(-0.1, steps[-1, modal_taylor.HI], 990),
                           steps[:7, modal_taylor.HI]))
    rows = [np.empty((len(taus), tables.shape[1])) for _ in range(2)]
    modal_taylor.ride_rows_at(steps, tables, ends, len(steps), taus, rows[0])
    compiled["ride_rows_at"](steps, tables, ends, len(steps), taus, rows[1])
    assert rows[0].tobytes() == rows[1].tobytes()


@pytest.mark.parametrize("name", SCENES)
def test_a_riding_phase_samples_each_time_in_the_step_that_holds_it(name):
    """states_at over many times at once: each time's rows those of the last step starting at
    or before it (bisected here by the standard library), Horner's rule at its theta there, or
    the step's end from its end on; the contact point's x and v their sums in mode order; and
    state / modal_state one time after another on a twin phase, the same floats."""
    fields = SCENES[name]
    ride, twin = _riding(fields), _riding(fields)
    end = ride.next_event(3.0)
    horizon = 3.0 if end is None else end
    assert twin.next_event(3.0) == end
    taus = np.linspace(0.0, horizon, 301)
    rows = ride.states_at(taus)
    n = ride.modes.count
    count = int(ride._counts[modal_taylor.COUNT])
    steps, tables, ends = ride._steps[:count], ride._tables[:count], ride._ends[:count]
    phi = ride.modes.phi
    for tau, row in zip(taus.tolist(), rows, strict=True):
        i = max(bisect.bisect_right(steps[:, modal_taylor.LO].tolist(), tau) - 1, 0)
        lo, h, hi = steps[i].tolist()
        expected = ends[i] if tau >= hi else np.array(
            [modal_taylor.horner(table_row, (tau - lo) / h) for table_row in tables[i]])
        x = v = 0.0
        for k in range(n):
            x += phi[k] * expected[k]
            v += phi[k] * expected[n + k]
        assert (x, v, *expected[:2 * n + 1].tolist()) == tuple(row.tolist())
        q, p = twin.modal_state(tau)
        assert (*twin.state(tau)[:2], *q, *p) == tuple(row[:2 + 2 * n].tolist())
