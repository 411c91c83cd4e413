"""The structure under the quadratic Morison drag in a flight, for the compiled search and march:
its Taylor steps made on demand in arrays, and the functions the flight search and the march of
bounces call in place of the closed forms' (docs/explanation/morison.md).

In flight the structure obeys ``m x'' + c x' + k x = B_s |u - x'| (u - x')``, which has no closed
form: :class:`~iceimpact.solvers.exact.DraggedFlight` integrates it by the Taylor steps of
:class:`~.taylor.StickingTaylor` (no drag on an ice, B_s on the structure, at most a natural
period long), each from the state the previous one ended in, and its root search is RootSearch's
with those steps' polynomials as the motion, :func:`~iceimpact.physics.structure.dragged_bounds`
as the structure's bounds, no clearance and steps of at most a period.

Here the same steps are made by the same kernel (:func:`~.taylor.ordinary_step`) into arrays
(:func:`new_steps`), from the flight's anchor, as the search asks for later times
(:func:`_dragged_motion`), and :func:`~.flight_search.flight_root` and
:func:`~iceimpact.solvers.exact.bounces.bounce_march` are compiled a second time with this
module's functions in place of the closed forms' (:func:`compiled_root`): one source for both
structures, RootSearch's steps on DraggedFlight's floats. A step on which the relative flow
u - x' may change sign (its root is found in Python, by brentq), a step the compiled kernels hand
back (:class:`~.taylor.HandBack`), a flight longer than the arrays hold or a step that fails
marks the steps failed (:func:`_failed`): the march then hands the flight back to Python before
changing anything, and DraggedFlight makes it from its anchor, the same steps.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...compiled import fields
from ...physics.structure import dragged_acceleration, dragged_bounds
from .flight_search import _ice_motion, compile_root, python_root, signature
from .taylor import StickingTaylor
from .taylor_series import NO_ROOT, ORDER, SAMPLES, horner_columns, ordinary_step

#: The flight's constants, the fields of the first array of the steps: the flow speed, B_s, the
#: structure's mass, damping, stiffness, omega_n^2, the longest step (a natural period) and the
#: anchor (x0, v0).
FLIGHT = fields("FlightConstants", "U", "B", "MASS", "DAMPING", "STIFFNESS", "OMEGA2", "PERIOD",
                "X0", "V0")
#: The counters, the fields of the second: the steps made, whether making one failed.
COUNTERS = fields("StepCounters", "COUNT", "FAILED")

#: Taylor steps a flight keeps (about as many natural periods): a longer flight is Python's.
CAPACITY = 512


def new_steps(taylor: StickingTaylor, omega2: float, capacity: int = CAPACITY) -> tuple:
    """The arrays of a flight's steps for ``taylor`` (a DraggedFlight's stepper: the flow
    speed, B_s, the structure's coefficients, the longest step and the constants of its
    recurrence) and omega_n^2: (Q, I, the steps' starts, lengths, ends, coefficient tables
    (order, column) and end states, then :func:`~.taylor.ordinary_step`'s work arrays and
    constants)."""
    q = np.zeros(len(FLIGHT))
    q[:FLIGHT.X0] = (taylor.u, taylor.structure_B, taylor.total, taylor.c, taylor.k, omega2,
                taylor.max_step)
    order_over, reciprocals, exponents = (np.ascontiguousarray(c, dtype=float)
                                          for c in taylor._constants)
    return (q, np.zeros(len(COUNTERS), dtype=np.int64), np.zeros(capacity), np.zeros(capacity),
            np.zeros(capacity), np.zeros((capacity, ORDER + 1, 3)), np.zeros((capacity, 3)),
            np.zeros(ORDER + 1), np.zeros(ORDER), np.zeros((5, ORDER + 1)), np.zeros(ORDER + 1),
            np.zeros((2, SAMPLES + 2, ORDER + 1)), np.zeros((2, SAMPLES + 2, 8)),
            np.zeros((SAMPLES + 2, 2)), np.zeros((SAMPLES, 2), dtype=bool), order_over,
            reciprocals, exponents)


def _make_step(integrated):
    """The next step (``DraggedFlight._step_from``): from the anchor (x0, v0, P = 0) at 0, else
    from the last step's end; False (and the steps marked failed) where it is not an ordinary
    step ending in a finite state after its start, or no room is left."""
    (q, ints, los, hs, his, tables, ends, rs, fs, table, powers, terms, partial, sums, proven,
     order_over, reciprocals, exponents) = integrated
    count = ints[COUNTERS.COUNT]
    if ints[COUNTERS.FAILED] != 0 or count == los.size:
        ints[COUNTERS.FAILED] = 1
        return False
    if count == 0:
        lo, x, v, p = 0.0, q[FLIGHT.X0], q[FLIGHT.V0], 0.0
    else:
        lo, x, v, p = his[count - 1], ends[count - 1, 0], ends[count - 1, 1], ends[count - 1, 2]
    outcome, h, theta_end = ordinary_step(
        lo, x, v, p, math.inf, False, q[FLIGHT.U], 0.0, q[FLIGHT.B], q[FLIGHT.DAMPING],
        q[FLIGHT.STIFFNESS], 0.0, q[FLIGHT.PERIOD], order_over, reciprocals, exponents, rs, fs,
        table, powers, terms, partial, sums, proven, 0.0)
    if outcome != NO_ROOT:  # (a sign change of u - v may lie on it: Python's _first_root)
        ints[COUNTERS.FAILED] = 1
        return False
    step_table = tables[count]
    for n in range(ORDER + 1):
        for j in range(3):
            step_table[n, j] = table[j, n]
    x_hi, v_hi, p_hi = horner_columns(step_table, theta_end)
    hi = lo + h
    if not (math.isfinite(x_hi) and math.isfinite(v_hi) and math.isfinite(p_hi) and hi >= lo):
        ints[COUNTERS.FAILED] = 1
        return False
    if count > 0 and hi == lo and los[count - 1] == lo:  # (stalled: Python raises)
        ints[COUNTERS.FAILED] = 1
        return False
    los[count], hs[count], his[count] = lo, h, hi
    ends[count, 0], ends[count, 1], ends[count, 2] = x_hi, v_hi, p_hi
    ints[COUNTERS.COUNT] = count + 1
    return True


def _dragged_structure(t, integrated):
    """(x - x0, v) at t (s from the anchor): ``DraggedFlight._structure``, the steps made up to
    t; NaN where they cannot be."""
    q, ints, los, hs, his, tables, ends = integrated[:7]
    if t <= 0.0:
        return 0.0, q[FLIGHT.V0]
    if ints[COUNTERS.COUNT] == 0 and not _make_step(integrated):
        return math.nan, math.nan
    while t > his[ints[COUNTERS.COUNT] - 1]:
        if not _make_step(integrated):
            return math.nan, math.nan
    i = ints[COUNTERS.COUNT] - 1
    while i > 0 and los[i] > t:  # the last step starting at or before t
        i -= 1
    if t >= his[i]:
        return ends[i, 0] - q[FLIGHT.X0], ends[i, 1]
    x, v, _ = horner_columns(tables[i], (t - los[i]) / hs[i])
    return x - q[FLIGHT.X0], v


def _dragged_gap_point(context, t):
    """``flight_search._gap_point`` for the structure in Taylor steps (``DraggedFlight``'s
    ``gap_and_rate``: its ``_structure`` and the ice's closed form)."""
    gap0, form, k, rate, w0, r0, quadratic, integrated = context
    dx, v = _dragged_structure(t, integrated)
    dz, w = _ice_motion(t, rate, w0, r0, quadratic)
    return gap0 + (dx - dz), v - w, (dx, v, dz, w)


def _dragged_probe(x, v, offset, mass, damping, stiffness, omega2, over, s_slow, s_fast, u,
                   integrated):
    """``flight_search._structure_probe`` for the structure under the quadratic Morison drag:
    :func:`~iceimpact.physics.structure.dragged_bounds` (``DraggedFlight.probe``)."""
    q = integrated[0]
    return dragged_bounds(x, v, u, q[FLIGHT.MASS], q[FLIGHT.DAMPING], q[FLIGHT.STIFFNESS],
                          q[FLIGHT.OMEGA2], q[FLIGHT.B])


def _no_clearance(x, v, z, w, offset, omega2, sigma, over, s_slow, s_fast, u, coef, quadratic,
                  integrated):
    """``flight_search._clearance`` where the structure has no closed-form envelope
    (``DraggedFlight.clearance`` is None): nothing proven."""
    return 0.0


def _dragged_sample(sample, tau, x0, v0, z0, w0, form, k, rate, w0_c, r0, quadratic,
                    integrated):
    """``bounces._flight_sample`` for the structure in Taylor steps: the floats of
    ``DraggedFlight.states_at``."""
    dx, v = _dragged_structure(tau, integrated) if tau > 0.0 else (0.0, v0)
    dz, w = _ice_motion(tau, rate, w0_c, r0, quadratic)
    return x0 + dx, v, z0 + dz, w


def _dragged_accel(t, tau, x, v, v_plus, offset, mass, damping, stiffness, u, integrated):
    """``bounces._structure_accel`` under the quadratic Morison drag
    (``DraggedStructure.acceleration`` at x, v_plus)."""
    q = integrated[0]
    return dragged_acceleration(x, v_plus, u, q[FLIGHT.MASS], q[FLIGHT.DAMPING],
                                q[FLIGHT.STIFFNESS], q[FLIGHT.B])


def _dragged_new_flight(integrated, t, x0, v0):
    """A new flight from (x0, v0) at time t: no steps yet; its anchor (x0, v0)."""
    q, ints = integrated[0], integrated[1]
    q[FLIGHT.X0], q[FLIGHT.V0] = x0, v0
    ints[COUNTERS.COUNT] = 0
    ints[COUNTERS.FAILED] = 0
    return x0, v0


def _dragged_failed(integrated):
    """Whether a step could not be made (:func:`_make_step`)."""
    return integrated[1][COUNTERS.FAILED] != 0


#: The functions the search and the march call by name, for the structure in Taylor steps.
SEARCH_CALLEES = {"_gap_point": _dragged_gap_point, "_structure_probe": _dragged_probe,
                  "_clearance": _no_clearance}
MARCH_CALLEES = {"_flight_sample": _dragged_sample, "_structure_accel": _dragged_accel,
                 "_new_flight": _dragged_new_flight, "_failed": _dragged_failed}

#: :func:`~.flight_search.flight_root` run as Python on this module's functions (the tests'
#: reference for the compiled search and march)
PYTHON_ROOT = python_root(**SEARCH_CALLEES)


def steps_type(numba: Any) -> Any:
    """numba's type of the arrays of :func:`new_steps`."""
    f8, i8 = numba.float64, numba.int64
    a1, a2, a3 = f8[::1], f8[:, ::1], f8[:, :, ::1]
    return numba.types.Tuple((a1, i8[::1], a1, a1, a1, a3, a2, a1, a1, a2, a1, a3, a3, a2,
                              numba.boolean[:, ::1], a1, a1, a1))


def compiled_callees(numba: Any, kernels: Any, search: dict[str, Any]) -> dict[str, Any]:
    """This module's functions compiled for the search and the march (by the names they take
    there), on the Taylor steps' compiled kernels (``taylor.KERNELS.dispatchers``) and the
    flight search's (``flight_search.compiled_callees``); ``flight_root`` is the search
    compiled on them."""
    from ...compiled import jit

    steps = steps_type(numba)

    def compiled(function: Any, **callees: Any) -> Any:
        return jit(numba, signature(numba, function, steps), function, **callees)

    ice_motion = search["_ice_motion"]
    make = compiled(_make_step, ordinary_step=kernels["ordinary_step"],
                    horner_columns=kernels["horner_columns"])
    structure = compiled(_dragged_structure, _make_step=make,
                         horner_columns=kernels["horner_columns"])
    acceleration = compiled(dragged_acceleration)
    callees = {"_gap_point": compiled(_dragged_gap_point, _dragged_structure=structure,
                                      _ice_motion=ice_motion),
               "_structure_probe": compiled(_dragged_probe,
                                            dragged_bounds=compiled(
                                                dragged_bounds,
                                                dragged_acceleration=acceleration)),
               "_clearance": compiled(_no_clearance),
               "_ice_accel": search["_ice_accel"], "plan": search["plan"]}
    return {
        "flight_root": compile_root(numba, steps, callees),
        "_flight_sample": compiled(_dragged_sample, _dragged_structure=structure,
                                   _ice_motion=ice_motion),
        "_structure_accel": compiled(_dragged_accel, dragged_acceleration=acceleration),
        "_new_flight": compiled(_dragged_new_flight),
        "_failed": compiled(_dragged_failed),
    }
