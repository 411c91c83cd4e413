"""The modal structure in a flight, for the one-function flight search: the gap as the sum of the
modes' closed forms, the contact point's bounds as the sums of the modes' bounds, its envelope
(docs/explanation/modes.md).

:func:`~.flight_search.flight_root` takes the structure's motion through the functions it calls
by name (``_gap_point``, ``_structure_probe``, ``_clearance``) and the ``integrated`` argument
they read. Here ``integrated`` is two arrays (:func:`new_modes`): the modes' constants, one row
per mode (:data:`MODE`: phi, the form and the eight constants of its free response y = q - q_p
from the flight's anchor, its oscillator's, the speed rho of its particular solution q_p and
q_p at the anchor; :mod:`iceimpact.physics.modes`), and the modal state (:data:`STATE`: the
anchor's free responses, and the point evaluated last). :func:`_modal_gap_point` evaluates each
mode's closed form (``under_increment`` or ``aperiodic_increment``, as
``Oscillator.deviation_increment``) and keeps the modal state there; the probe and the
clearance that follow at the same point read it: flight_root probes the last point it evaluated
(its ``at``, kept by the descent and the bracket too).

The search is compiled a second time on these functions (:data:`KERNEL`), or run as Python
with them where numba is not (:data:`PYTHON_ROOT`): the same steps and floats either way, and
RootSearch's on :class:`~iceimpact.solvers.exact.modal.ModalFlight`'s own ``probe`` and
``clearance`` (the tests compare them).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...compiled import compile_or_none, entry_point, fields, jit
from ...physics.structure import (
    FORM_UNDER,
    aperiodic_increment,
    response_constants,
    under_increment,
)
from ..base import GAP_ULPS
from .flight_search import (
    _amplitude,
    _ice_motion,
    _structure_probe,
    compile_root,
    compiled_callees,
    python_root,
    signature,
)

#: The columns of a mode's row: phi_k, the form of its free response and its eight constants from
#: the anchor (``response_constants`` of y, y'), its oscillator's mass, damping, stiffness,
#: omega^2, sigma, over-damped flag and exponents, the speed rho_k of its particular solution and
#: the particular solution at the anchor.
MODE = fields("ModeConstants", "PHI", "FORM", "C0", "C1", "C2", "C3", "C4", "C5", "C6", "C7",
              "MASS", "DAMPING", "STIFFNESS", "OMEGA2", "SIGMA", "OVER", "S_SLOW", "S_FAST",
              "RHO", "OFF0")
#: The rows of the modal state: the anchor's free responses y and y', the last point
#: evaluated's y - y0 and y', and its time (in the first column).
STATE = fields("ModalState", "Y0", "YD0", "DY", "YD", "T")


def new_modes(modes: Any, t0: float, q0: Any, p0: Any) -> tuple[np.ndarray, np.ndarray]:
    """The arrays of a flight of ``modes`` (:class:`~iceimpact.physics.modes.Modes`) from the
    modal state (q0, q0') at time t0: the constants and the state, its last point the anchor."""
    n = modes.count
    constants = np.empty((n, len(MODE)))
    state = np.zeros((len(STATE), n))
    offsets = modes.offsets(t0)
    y0, yd0 = modes.deviations(t0, q0, p0)
    for k, osc in enumerate(modes.oscillators):
        row = constants[k]
        row[MODE.PHI], row[MODE.FORM] = modes.phi[k], osc.form
        s_slow, s_fast = osc.exponents
        row[MODE.C0:MODE.C7 + 1] = response_constants(osc.form, 0.0, osc.sigma, osc.omega,
                                                      osc.omega2, s_slow, s_fast, y0[k], yd0[k])
        row[MODE.MASS], row[MODE.DAMPING] = osc.mass, osc.damping
        row[MODE.STIFFNESS], row[MODE.OMEGA2], row[MODE.SIGMA] = (osc.stiffness, osc.omega2,
                                                                  osc.sigma)
        row[MODE.OVER] = 1.0 if osc.form >= 2 else 0.0
        row[MODE.S_SLOW], row[MODE.S_FAST] = s_slow, s_fast
        row[MODE.RHO], row[MODE.OFF0] = modes.drift[k], offsets[k]
        state[STATE.Y0, k], state[STATE.YD0, k], state[STATE.YD, k] = y0[k], yd0[k], yd0[k]
    return constants, state


def _modal_gap_point(context, t):
    """``flight_search._gap_point`` for the modes: each mode's increment from the anchor (its
    free response's, plus rho t) summed times its phi (``ModalFlight._motion``'s order), the
    ice's closed form; the free responses at t kept in the state's last point."""
    gap0, form, k, rate, w0, r0, quadratic, integrated = context
    constants, state = integrated
    dx = 0.0
    v = 0.0
    for j in range(constants.shape[0]):
        c = constants[j]
        if int(c[MODE.FORM]) == FORM_UNDER:  # the free response's y - y0, y'
            dy, yd = under_increment(t, c[MODE.C0], c[MODE.C1], c[MODE.C2], c[MODE.C3],
                                    c[MODE.C4], c[MODE.C5])
        else:
            dy, yd = aperiodic_increment(t, int(c[MODE.FORM]), c[MODE.C0], c[MODE.C1],
                                        c[MODE.C2], c[MODE.C3], c[MODE.C4], c[MODE.C5],
                                        c[MODE.C6], c[MODE.C7])
        state[STATE.DY, j] = dy
        state[STATE.YD, j] = yd
        rho = c[MODE.RHO]
        dx += c[MODE.PHI] * (dy + rho * t)
        v += c[MODE.PHI] * (yd + rho)
    state[STATE.T, 0] = t
    dz, w = _ice_motion(t, rate, w0, r0, quadratic)
    return gap0 + (dx - dz), v - w, (dx, v, dz, w)


def _modal_probe(x, v, offset, mass, damping, stiffness, omega2, over, s_slow, s_fast, u,
                 integrated):
    """``flight_search._structure_probe`` for the modes at the last point evaluated: the
    contact point's acceleration and the sums of |phi_k| times each mode's bounds
    (``Modes.deviation_bounds``, its free response's, offset 0); NaN where a mode's amplitude
    bound is at the scales of its hypot form."""
    constants, state = integrated
    a = 0.0
    a_max = 0.0
    j_max = 0.0
    for j in range(constants.shape[0]):
        c = constants[j]
        phi = c[MODE.PHI]
        if phi == 0.0:
            continue
        ak, ak_max, jk_max = _structure_probe(
            state[STATE.Y0, j] + state[STATE.DY, j], state[STATE.YD, j], 0.0,
            c[MODE.MASS], c[MODE.DAMPING], c[MODE.STIFFNESS], c[MODE.OMEGA2], int(c[MODE.OVER]),
            c[MODE.S_SLOW], c[MODE.S_FAST], u, 0)
        size = phi if phi > 0.0 else -phi
        a += phi * ak
        a_max += size * ak_max
        j_max += size * jk_max
    return a, a_max, j_max


def _modal_clearance(x, v, z, w, offset, omega2, sigma, over, s_slow, s_fast, u, coef,
                     quadratic, integrated):
    """``ModalFlight.clearance`` at the last point evaluated: the contact point stays within
    ``sum |phi_k| R_k`` of ``sum phi_k q_p`` (``Modes.reach``), which moves at ``sum phi_k
    rho_k``, and the ice downstream no faster than its speed bound; NaN where a mode's
    amplitude bound is at the scales of its hypot form (RootSearch's)."""
    constants, state = integrated
    t = state[STATE.T, 0]
    centre = 0.0
    reach = 0.0
    drift = 0.0
    for j in range(constants.shape[0]):
        c = constants[j]
        phi = c[MODE.PHI]
        if phi == 0.0:
            continue
        radius = _amplitude(state[STATE.Y0, j] + state[STATE.DY, j], state[STATE.YD, j],
                            c[MODE.OMEGA2], int(c[MODE.OVER]), c[MODE.S_SLOW], c[MODE.S_FAST])
        if radius != radius:
            return math.nan
        centre += phi * (c[MODE.OFF0] + c[MODE.RHO] * t)
        reach += (phi if phi > 0.0 else -phi) * radius
        drift += phi * c[MODE.RHO]
    margin = (centre - reach - z) - GAP_ULPS * (abs(x) + abs(z) + reach + abs(centre))
    if not margin > 0.0:
        return 0.0
    speed = max(w, u, 0.0) if coef > 0.0 else max(w, 0.0)  # downstream_speed_bound
    speed += max(0.0, -drift)  # the envelope's centre moving upstream
    return math.inf if speed == 0.0 else margin / speed


#: The functions the search calls by name, for the modes
SEARCH_CALLEES = {"_gap_point": _modal_gap_point, "_structure_probe": _modal_probe,
                  "_clearance": _modal_clearance}
#: :func:`~.flight_search.flight_root` run as Python on this module's functions
PYTHON_ROOT = python_root(**SEARCH_CALLEES)


def modes_type(numba: Any) -> Any:
    """numba's type of the arrays of :func:`new_modes`."""
    a2 = numba.float64[:, ::1]
    return numba.types.Tuple((a2, a2))


def _build(numba: Any) -> Any:
    search = compiled_callees(numba)
    modes = modes_type(numba)

    def compiled(function: Any, **callees: Any) -> Any:
        return jit(numba, signature(numba, function, modes), function, **callees)

    callees = {"_gap_point": compiled(_modal_gap_point, _ice_motion=search["_ice_motion"],
                                      under_increment=search["under_increment"],
                                      aperiodic_increment=search["aperiodic_increment"]),
               "_structure_probe": compiled(_modal_probe,
                                            _structure_probe=search["_structure_probe"]),
               "_clearance": compiled(_modal_clearance, _amplitude=search["_amplitude"]),
               "_ice_accel": search["_ice_accel"], "plan": search["plan"]}
    return entry_point(compile_root(numba, modes, callees))


#: The search compiled on the modes where numba is, else None (:data:`PYTHON_ROOT` runs)
COMPILED = compile_or_none("the modal flight search", _build)
KERNEL = PYTHON_ROOT if COMPILED is None else COMPILED
