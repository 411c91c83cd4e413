"""The modal structure in a flight, for the one-function flight search: the gap as the sum of the
modes' closed forms, the contact point's bounds as the sums of the modes' bounds, its envelope
(docs/explanation/modes.md).

:func:`~.flight_search.flight_root` takes the structure's motion through the functions it calls
by name (``_gap_point``, ``_structure_probe``, ``_clearance``) and the ``integrated`` argument
they read. Here ``integrated`` is four arrays (:func:`new_modes`): the modes' constants, one
row per mode (:data:`MODE`: phi, the form and the eight constants of its free response y = q -
q_p from the flight's anchor, its oscillator's, the speed rho of its particular solution q_p and
q_p at the anchor; :mod:`iceimpact.physics.modes`), the modal state (:data:`STATE`: the anchor's
free responses, and the point evaluated last), the anchor with the loads (:data:`ANCHOR`: the
modal state (q, q') at the anchor, the loads, a column per mode) and the samples' modal states
(the march of bounces writes them). :func:`_modal_gap_point`
evaluates each mode's closed form (``under_increment`` or ``aperiodic_increment``, as
``Oscillator.deviation_increment``) and keeps the modal state there; the probe and the clearance
that follow at the same point read it: flight_root probes the last point it evaluated (its
``at``, kept by the descent and the bracket too).

The search is compiled a second time on these functions (:data:`KERNEL`), or run as Python
with them where numba is not (:data:`PYTHON_ROOT`): the same steps and floats either way, and
RootSearch's on :class:`~iceimpact.solvers.exact.modal.ModalFlight`'s own ``probe`` and
``clearance`` (the tests compare them).

The march of bounces (:func:`~iceimpact.solvers.exact.bounces.bounce_march`) is compiled a third
time with :data:`MARCH_CALLEES`: at an impact the modes' state at the contact (``_modal_accel``:
``ModalSolver``'s modal state there, each velocity changed by ``phi_k J / m_k``, and the contact
point's free acceleration, ``Modes.contact_acceleration``), the next flight's anchor from it
(``_modal_new_flight``: :func:`new_modes`' constants, the contact point's (x0, v0) as
``Modes.contact`` sums them) and the states at the samples (``_modal_sample``:
``ModalFlight.state``). Each writes out the floats of the Python objects, in their order.
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
from . import flight_search
from .flight_search import (
    _amplitude,
    _ice_motion,
    _structure_probe,
    compile_root,
    python_root,
    signature,
)

#: The columns of a mode's row: phi_k, the form of its free response and its eight constants from
#: the anchor (``response_constants`` of y, y'), its oscillator's mass, damping, stiffness,
#: omega^2, sigma, over-damped flag and exponents, the speed rho_k of its particular solution and
#: the particular solution at the anchor, the oscillator's omega (damped frequency).
MODE = fields("ModeConstants", "PHI", "FORM", "C0", "C1", "C2", "C3", "C4", "C5", "C6", "C7",
              "MASS", "DAMPING", "STIFFNESS", "OMEGA2", "SIGMA", "OVER", "S_SLOW", "S_FAST",
              "RHO", "OFF0", "OMEGA")
#: The rows of the modal state: the anchor's free responses y and y', the last point
#: evaluated's y - y0 and y', and its time (in the first column).
STATE = fields("ModalState", "Y0", "YD0", "DY", "YD", "T")
#: The rows of the anchor and the loads, a column per mode: the modal state (q, q') at the
#: flight's anchor, the modal state at an impact taken by the march (the next anchor), the load
#: L_k given at SINCE and its rate R_k (``Modes.loads_at``), the held load's static deflection
#: (``Modes.offsets`` while HELD is 1.0) and phi_k m_eff / m_k (``Modes.share``).
ANCHOR = fields("ModalAnchor", "Q0", "P0", "QN", "PN", "LOAD", "RATE", "SINCE", "HELD",
                "OFFSET", "SHARE")


def new_modes(modes: Any, t0: float, q0: Any,
              p0: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The arrays of a flight of ``modes`` (:class:`~iceimpact.physics.modes.Modes`) from the
    modal state (q0, q0') at time t0: the constants, the state (its last point the anchor), the
    anchor with the loads, and the samples' modal states (none: the march of bounces gives its
    own, a row (q, q') per sample)."""
    n = modes.count
    constants = np.empty((n, len(MODE)))
    state = np.zeros((len(STATE), n))
    anchor = np.zeros((len(ANCHOR), n))
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
        row[MODE.OMEGA] = osc.omega
        state[STATE.Y0, k], state[STATE.YD0, k], state[STATE.YD, k] = y0[k], yd0[k], yd0[k]
        column = anchor[:, k]
        column[ANCHOR.Q0], column[ANCHOR.P0] = q0[k], p0[k]
        column[ANCHOR.LOAD], column[ANCHOR.RATE] = modes.loads[k], modes.rates[k]
        column[ANCHOR.SINCE], column[ANCHOR.HELD] = modes.since, 1.0 if modes.held else 0.0
        column[ANCHOR.OFFSET], column[ANCHOR.SHARE] = osc.offset, modes.share[k]
    return constants, state, anchor, np.empty((0, 2 * n))


def _modal_gap_point(context, t):
    """``flight_search._gap_point`` for the modes: each mode's increment from the anchor (its
    free response's, plus rho t) summed times its phi (``ModalFlight._motion``'s order), the
    ice's closed form; the free responses at t kept in the state's last point."""
    gap0, form, k, rate, w0, r0, quadratic, integrated = context
    constants, state = integrated[0], integrated[1]
    dx = 0.0
    v = 0.0
    for j in range(constants.shape[0]):
        dy, yd = _mode_increment(constants, j, t)
        state[STATE.DY, j] = dy
        state[STATE.YD, j] = yd
        rho = constants[j, MODE.RHO]
        phi = constants[j, MODE.PHI]
        dx += phi * (dy + rho * t)
        v += phi * (yd + rho)
    state[STATE.T, 0] = t
    dz, w = _ice_motion(t, rate, w0, r0, quadratic)
    return gap0 + (dx - dz), v - w, (dx, v, dz, w)


def _modal_probe(x, v, offset, mass, damping, stiffness, omega2, over, s_slow, s_fast, u,
                 integrated):
    """``flight_search._structure_probe`` for the modes at the last point evaluated: the
    contact point's acceleration and the sums of |phi_k| times each mode's bounds
    (``Modes.deviation_bounds``, its free response's, offset 0); NaN where a mode's amplitude
    bound is at the scales of its hypot form."""
    constants, state = integrated[0], integrated[1]
    a = 0.0
    a_max = 0.0
    j_max = 0.0
    for j in range(constants.shape[0]):
        phi = constants[j, MODE.PHI]
        if phi == 0.0:
            continue
        ak, ak_max, jk_max = _structure_probe(
            state[STATE.Y0, j] + state[STATE.DY, j], state[STATE.YD, j], 0.0,
            constants[j, MODE.MASS], constants[j, MODE.DAMPING], constants[j, MODE.STIFFNESS],
            constants[j, MODE.OMEGA2], int(constants[j, MODE.OVER]),
            constants[j, MODE.S_SLOW], constants[j, MODE.S_FAST], u, 0)
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
    constants, state = integrated[0], integrated[1]
    t = state[STATE.T, 0]
    centre = 0.0
    reach = 0.0
    drift = 0.0
    for j in range(constants.shape[0]):
        phi = constants[j, MODE.PHI]
        if phi == 0.0:
            continue
        radius = _amplitude(state[STATE.Y0, j] + state[STATE.DY, j], state[STATE.YD, j],
                            constants[j, MODE.OMEGA2], int(constants[j, MODE.OVER]),
                            constants[j, MODE.S_SLOW], constants[j, MODE.S_FAST])
        if radius != radius:
            return math.nan
        centre += phi * (constants[j, MODE.OFF0] + constants[j, MODE.RHO] * t)
        reach += (phi if phi > 0.0 else -phi) * radius
        drift += phi * constants[j, MODE.RHO]
    margin = (centre - reach - z) - GAP_ULPS * (abs(x) + abs(z) + reach + abs(centre))
    if not margin > 0.0:
        return 0.0
    speed = max(w, u, 0.0) if coef > 0.0 else max(w, 0.0)  # downstream_speed_bound
    speed += max(0.0, -drift)  # the envelope's centre moving upstream
    return math.inf if speed == 0.0 else margin / speed


def _mode_increment(constants, j, t):
    """Mode j's (row j of ``constants``, :data:`MODE`) free response from its anchor at t:
    (y - y0, y'), ``Oscillator.deviation_increment``'s closed form. (The row is read in place:
    a view of it would cost the compiled code two atomic reference counts per call.)"""
    form = int(constants[j, MODE.FORM])
    if form == FORM_UNDER:
        return under_increment(t, constants[j, MODE.C0], constants[j, MODE.C1],
                               constants[j, MODE.C2], constants[j, MODE.C3],
                               constants[j, MODE.C4], constants[j, MODE.C5])
    return aperiodic_increment(t, form, constants[j, MODE.C0], constants[j, MODE.C1],
                               constants[j, MODE.C2], constants[j, MODE.C3],
                               constants[j, MODE.C4], constants[j, MODE.C5],
                               constants[j, MODE.C6], constants[j, MODE.C7])


def _modal_flight_constants(form, offset, sigma, omega, omega2, s_slow, s_fast, x0, v0,
                            integrated):
    """``bounces._flight_constants`` for the modes: the structure's closed form is theirs (in
    ``integrated``); flight_root reads the anchor's speed as c5
    (``ModalFlight.kernel_constants``)."""
    return (0.0, 0.0, 0.0, 0.0, 0.0, v0, 0.0, 0.0)


def _modal_sample(sample, tau, x0, v0, z0, w0, form, k, rate, w0_c, r0, quadratic, integrated):
    """``bounces._flight_sample`` for the modes: the floats of ``ModalFlight.state`` (each
    mode's increment plus rho tau, summed times phi in mode order), and the modal state of
    ``ModalFlight.modal_state`` to row ``sample`` of the samples' array; the state rows
    untouched."""
    constants, anchor, samples = integrated[0], integrated[2], integrated[3]
    n = constants.shape[0]
    dx = 0.0
    v = 0.0
    for j in range(n):
        dy, yd = _mode_increment(constants, j, tau)
        rho = constants[j, MODE.RHO]
        dq = dy + rho * tau
        p = yd + rho
        samples[sample, j] = anchor[ANCHOR.Q0, j] + dq
        samples[sample, n + j] = p
        dx += constants[j, MODE.PHI] * dq
        v += constants[j, MODE.PHI] * p
    dz, w = _ice_motion(tau, rate, w0_c, r0, quadratic)
    return x0 + dx, v, z0 + dz, w


def _modal_accel(t, tau, x, v, v_plus, offset, mass, damping, stiffness, u, integrated):
    """``bounces._structure_accel`` for the modes, at the impact at time t (tau into the
    flight), the contact point's velocity v before it and v_plus after: the modal state there
    (``ModalFlight.remember``'s, kept in the state's last point as the search leaves it), each
    velocity changed by the impulse (``ModalSolver.modal_now``, ``Modes.velocity_change``) into
    the anchor's next state (QN, PN), and the contact point's acceleration without a contact
    force (``Modes.contact_acceleration``)."""
    constants, state, anchor = integrated[0], integrated[1], integrated[2]
    n = constants.shape[0]
    evaluated = state[STATE.T, 0] == tau  # (the search's last point: the root, most often)
    v_ref = 0.0  # (ModalSolver._take_now: the contact point's speed of that state)
    for j in range(n):
        if evaluated:
            dy, yd = state[STATE.DY, j], state[STATE.YD, j]
        else:
            dy, yd = _mode_increment(constants, j, tau)
            state[STATE.DY, j] = dy
            state[STATE.YD, j] = yd
        rho = constants[j, MODE.RHO]
        q = anchor[ANCHOR.Q0, j] + (dy + rho * tau)
        p = yd + rho
        anchor[ANCHOR.QN, j] = q
        anchor[ANCHOR.PN, j] = p
        v_ref += constants[j, MODE.PHI] * p
    state[STATE.T, 0] = tau
    dv = v_plus - v_ref
    a = 0.0
    for j in range(n):
        p = anchor[ANCHOR.PN, j]
        if v_plus != v_ref:
            p = p + anchor[ANCHOR.SHARE, j] * dv
            anchor[ANCHOR.PN, j] = p
        load = anchor[ANCHOR.LOAD, j] + anchor[ANCHOR.RATE, j] * (t - anchor[ANCHOR.SINCE, j])
        a += constants[j, MODE.PHI] * ((load - constants[j, MODE.DAMPING] * p
                                        - constants[j, MODE.STIFFNESS] * anchor[ANCHOR.QN, j])
                                       / constants[j, MODE.MASS])
    return a


def _modal_new_flight(integrated, t, x, v):
    """``bounces._new_flight`` for the modes: the flight from the state :func:`_modal_accel`
    took at the impact at time t, as :func:`new_modes` makes it (``Modes.offsets``,
    ``Modes.deviations``); returns the contact point's (x0, v0) there, ``Modes.contact``'s
    sums (the new ``ModalFlight``'s anchor; the ice starts there too, ``touching``)."""
    constants, state, anchor = integrated[0], integrated[1], integrated[2]
    x0 = 0.0
    v0 = 0.0
    for j in range(constants.shape[0]):
        q = anchor[ANCHOR.QN, j]
        p = anchor[ANCHOR.PN, j]
        anchor[ANCHOR.Q0, j] = q
        anchor[ANCHOR.P0, j] = p
        x0 += constants[j, MODE.PHI] * q
        v0 += constants[j, MODE.PHI] * p
        rho = constants[j, MODE.RHO]
        if anchor[ANCHOR.HELD, j] != 0.0:
            off = anchor[ANCHOR.OFFSET, j]
        else:
            load = anchor[ANCHOR.LOAD, j] + anchor[ANCHOR.RATE, j] * (t - anchor[ANCHOR.SINCE, j])
            off = (load - constants[j, MODE.DAMPING] * rho) / constants[j, MODE.STIFFNESS]
        y0 = q - off
        yd0 = p - rho
        k = response_constants(int(constants[j, MODE.FORM]), 0.0, constants[j, MODE.SIGMA],
                               constants[j, MODE.OMEGA], constants[j, MODE.OMEGA2],
                               constants[j, MODE.S_SLOW], constants[j, MODE.S_FAST], y0, yd0)
        for i in range(8):
            constants[j, MODE.C0 + i] = k[i]
        constants[j, MODE.OFF0] = off
        state[STATE.Y0, j] = y0
        state[STATE.YD0, j] = yd0
        state[STATE.DY, j] = 0.0
        state[STATE.YD, j] = yd0
    state[STATE.T, 0] = 0.0
    return x0, v0


def _modal_failed(integrated):
    """The modes' motion is closed forms: it never fails."""
    return False


#: The functions the search calls by name, for the modes
SEARCH_CALLEES = {"_gap_point": _modal_gap_point, "_structure_probe": _modal_probe,
                  "_clearance": _modal_clearance}
#: :func:`~.flight_search.flight_root` run as Python on this module's functions
PYTHON_ROOT = python_root(**SEARCH_CALLEES)


#: The functions the march of bounces calls by name (``bounces.STRUCTURE_CALLEES``), for the
#: modes, as Python (with :data:`PYTHON_ROOT`: the tests' reference for the compiled march)
MARCH_CALLEES = {"_flight_constants": _modal_flight_constants, "_flight_sample": _modal_sample,
                 "_structure_accel": _modal_accel, "_new_flight": _modal_new_flight,
                 "_failed": _modal_failed}


def modes_type(numba: Any) -> Any:
    """numba's type of the arrays of :func:`new_modes`."""
    a2 = numba.float64[:, ::1]
    return numba.types.Tuple((a2, a2, a2, a2))


_DISPATCHERS: dict[str, Any] = {}


def _search_callees(numba: Any) -> dict[str, Any]:
    """numba's dispatchers of the search on the modes (``flight_root``) and of a mode's
    increment (``_mode_increment``), compiled once."""
    if not _DISPATCHERS:
        search = flight_search.compiled_callees(numba)
        modes = modes_type(numba)

        def compiled(function: Any, **callees: Any) -> Any:
            return jit(numba, signature(numba, function, modes), function, borrows=True,
                       **callees)

        increment = jit(numba, (numba.float64[:, ::1], numba.int64, numba.float64),
                        _mode_increment, borrows=True,
                        under_increment=search["under_increment"],
                        aperiodic_increment=search["aperiodic_increment"])
        callees = {"_gap_point": compiled(_modal_gap_point, _ice_motion=search["_ice_motion"],
                                          _mode_increment=increment),
                   "_structure_probe": compiled(_modal_probe,
                                                _structure_probe=search["_structure_probe"]),
                   "_clearance": compiled(_modal_clearance, _amplitude=search["_amplitude"]),
                   "_ice_accel": search["_ice_accel"], "plan": search["plan"]}
        _DISPATCHERS.update(flight_root=compile_root(numba, modes, callees, borrows=True),
                            _mode_increment=increment)
    return _DISPATCHERS


def march_callees(numba: Any, response_constants: Any) -> dict[str, Any]:
    """numba's dispatchers of :data:`MARCH_CALLEES` and of the search (``flight_root``), by the
    names the march of bounces calls them, on the march's compiled ``response_constants``."""
    search = flight_search.compiled_callees(numba)
    own = _search_callees(numba)
    modes = modes_type(numba)

    def compiled(function: Any, **callees: Any) -> Any:
        return jit(numba, signature(numba, function, modes), function, borrows=True,
                   **callees)

    increment = own["_mode_increment"]
    return {"flight_root": own["flight_root"],
            "_flight_constants": compiled(_modal_flight_constants),
            "_flight_sample": compiled(_modal_sample, _mode_increment=increment,
                                       _ice_motion=search["_ice_motion"]),
            "_structure_accel": compiled(_modal_accel, _mode_increment=increment),
            "_new_flight": compiled(_modal_new_flight, response_constants=response_constants),
            "_failed": compiled(_modal_failed)}


#: The search compiled on the modes where numba is, else None (:data:`PYTHON_ROOT` runs)
COMPILED = compile_or_none("the modal flight search",
                           lambda numba: entry_point(_search_callees(numba)["flight_root"]))
KERNEL = PYTHON_ROOT if COMPILED is None else COMPILED
