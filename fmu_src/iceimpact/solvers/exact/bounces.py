"""The exact method's march of bounces, compiled: flight after flight, impact after impact, in one
call, with no Python call per impact.

Most of a run of the exact method (method 1) is bounces: a flight (structure on its closed form in
its damping regime, eq. 9-10; ice on its drag law, eq. 6-7 or 31-33) ends in an impact (eq. 16-17)
after which the bodies part, and the next flight starts at the contact. :func:`bounce_march`
makes those steps on plain floats: the flight's root search (:func:`~iceimpact.solvers.search.
flight_search.flight_root`), the contact rules' decisions (:func:`~iceimpact.solvers.
contact_rules.rounding_closing`, :func:`~iceimpact.physics.contact.impact`,
:func:`~iceimpact.solvers.contact_rules.bounce_closure`), the impact's record and, in a sampled
run, what the sampler records (the states at each flight's samples, by the flight search's
closed forms, the same floats as the sampler's array closed forms; the impulses in the order
:meth:`EventSolver.sample` adds them). Every one of those is the function the Python objects
call, so the compiled march and the Python one make the same steps on the same numbers, to the
bit.

Under the quadratic Morison drag on the structure (``DraggedFlight``: no closed form) the same
source is compiled a second time, the structure's motion, samples and acceleration those of its
Taylor steps (:mod:`~iceimpact.solvers.search.dragged`; :func:`dragged_kernel`): the names
swapped are one table, :data:`STRUCTURE_CALLEES`. The march's state is three arrays indexed by
the fields of their tables, :data:`FLOATS`, :data:`INTS` and :data:`PARAMS`.

It hands the march back to Python, before changing anything, at whatever else comes: the
horizon, an impact after which the bodies do not part (a chatter or Zeno sequence closed, a
plastic impact, sticking), a contact at rounding level, an impact beyond the step's budget
(Python raises its refusal), a step of the root search that is not its common one, a Taylor
step of a dragged structure that the kernel does not make (:mod:`~iceimpact.solvers.search.
dragged`). Python then goes on from the same flight exactly as it would have
(:class:`BounceMarch`).

Where numba is not installed (or ``ICEIMPACT_PURE`` is set) nothing is compiled and the Python
march runs alone: :func:`bounce_march` run as Python would be slower than the objects it stands
for (numpy scalars), so it is used only compiled (and by the tests, which run it as Python too).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ...compiled import compile_or_none, entry_point, fields, jit, rebound
from ...physics.contact import contact_force, impact, impact_impulse
from ...physics.ice import linear_flight_constants, quadratic_flight_constants
from ...physics.structure import response_constants, under_constants
from ..contact_rules import bounce_closure, rounding_closing
from ..search import dragged, flight_search, modal_search, taylor
from ..search.flight_search import GENERIC, ROOT, _ice_accel, _motion, flight_root
from ..search.taylor import HandBack
from .flight import DraggedFlight, Flight
from .sampling import first_sample_after
from .segment import _time_eps

if TYPE_CHECKING:
    from .context import BounceHost

# The march's state, in three arrays the kernel reads (P) and reads and writes (F, N), each
# indexed by the fields of its table: F[FLOATS.T0], N[INTS.STATUS], P[PARAMS.MASS].

#: F, the march's floats
FLOATS = fields(
    "Floats",
    # the current flight: its anchor (t, x, v, z, w), its start and its time resolution
    "T0", "X0", "V0", "Z0", "W0", "START", "TIME_EPS",
    # its search: the frontier, the probe kept there (f, f', f'', the bound of f'', the jerk)
    "A", "PROBED_AT", "PF", "PDF", "PD2", "PBOUND", "PJERK",
    # the root found (NaN: none) and the state there (x - x0, v, z - z0, w)
    "ROOT_AT", "RDX", "RV", "RDZ", "RW",
    # the march's impulse, the step's start (the sampler's impact budget), the march's end and
    # start
    "IMPULSE", "STEP_START", "T_END", "T_START",
)
#: N, the march's integers
INTS = fields(
    "Ints",
    # the search's counters
    "ITERATIONS", "CREEP",
    # the next sample, the sample interval whose impact budget runs, the impact count and the
    # budget's limit
    "SAMPLE", "INTERVAL", "COUNT", "LIMIT",
    # the records written (impacts, impulses), the outcome (END ...), the events taken
    "N_IMPACTS", "N_TARGETS", "STATUS", "EVENTS",
    # whether the march stops at its first impact; the number of sample times (0: a march to
    # F[FLOATS.T_END])
    "STOP_AT_EVENT", "N_TIMES",
)
#: P, the scene's constants
PARAMS = fields(
    "Params",
    # the structure's oscillator (with the linearised Morison drag, if on): its offset, mass,
    # damping, stiffness, omega_n^2, decay rate and damped frequency, its over-damped
    # exponents (Oscillator.exponents) and the form of its closed form
    "OFFSET", "MASS", "DAMPING", "STIFFNESS", "OMEGA2", "SIGMA", "OMEGA", "S_SLOW", "S_FAST",
    "FORM",
    # the flow speed, the ice's drag law (its coefficient, 1.0 if quadratic else 0.0)
    "U", "COEF", "QUADRATIC",
    # the contact rules': the structure's and the ice's masses at an impact and their reduced
    # mass (kg), omega_n, the restitution coefficient, the chatter time, whether a Zeno
    # sequence is followed (1.0) or closed, the bounce's budget, the time resolution, the gap's
    # rounding noise (relative, absolute)
    "STRUCTURE_MASS", "ICE_MASS", "REDUCED_MASS", "OMEGA_N", "E", "CHATTER", "FOLLOW_ZENO",
    "BUDGET", "TIME_RESOLUTION", "GAP_RELATIVE", "GAP_ABSOLUTE",
    # the impacts allowed per step; the root search's longest step
    "MAX_IMPACTS", "MAX_STEP",
)

def oscillator_fields(search_constants: Sequence[float], omega: float) -> dict[str, float]:
    """:data:`PARAMS`' fields of the structure's oscillator (OFFSET to FORM), from the nine
    constants of its flight search (``Oscillator.search_constants``' order: offset, mass,
    damping, stiffness, omega^2, sigma, the over-damped exponents, the form) and its damped
    frequency omega."""
    offset, mass, damping, stiffness, omega2, sigma, s_slow, s_fast, form = search_constants
    return {"OFFSET": offset, "MASS": mass, "DAMPING": damping, "STIFFNESS": stiffness,
            "OMEGA2": omega2, "SIGMA": sigma, "OMEGA": omega, "S_SLOW": s_slow,
            "S_FAST": s_fast, "FORM": float(form)}


#: The outcomes: the flight reaches the end with no event before it; its next event is
#: Python's to take; an impact ended the march (stop_at_event); the records are full (the
#: caller empties them and calls again).
END, EVENT, STOPPED, FULL = 0, 1, 2, 3

#: No impact budget (a march outside a step): a count no run reaches.
NO_LIMIT = 2 ** 62

#: Records kept between two returns to Python (the impacts' 64 kB).
CAPACITY = 1024


def _flight_sample(sample, tau, x0, v0, z0, w0, form, k, rate, w0_c, r0, quadratic, integrated):
    """A flight's state (x, v, z, w) at ``sample``, tau (s) from its anchor: the flight
    search's closed forms, the floats of ``Flight.state_array`` (its ice increment is
    0.0 + dz, the same float as dz but for the sign of a zero)."""
    dx, v, dz, w = _motion(tau, form, k, rate, w0_c, r0, quadratic, integrated)
    return x0 + dx, v, z0 + (0.0 + dz), w


def _flight_constants(form, offset, sigma, omega, omega2, s_slow, s_fast, x0, v0, integrated):
    """The constants of the structure's free response from (x0, v0): ``response_constants``
    (``Flight.kernel_constants``)."""
    return response_constants(form, offset, sigma, omega, omega2, s_slow, s_fast, x0, v0)


def _structure_accel(t, tau, x, v, v_plus, offset, mass, damping, stiffness, u, integrated):
    """The structure's acceleration at the impact at time t (tau into the flight), at x with the
    velocity v_plus after it (v before): ``Oscillator.acceleration``."""
    return -(damping * v_plus + stiffness * (x - offset)) / mass


def _new_flight(integrated, t, x, v):
    """A flight starts at time t from the contact at (x, v): its anchor (x0, v0), where the ice
    starts too; (x, v) for a closed form (the dragged structure's Taylor steps start again
    there; the modes' anchor is their own state's sum)."""
    return x, v


def _failed(integrated):
    """Whether the structure's motion could not be made: never for a closed form (the dragged
    structure's Taylor steps may fail)."""
    return False


#: What :func:`bounce_march` calls, by the name it calls, that depends on how the structure
#: moves in flight. The march is one source run two ways: as written, on the closed forms of
#: the damped oscillator (this module's functions and the flight search's), and, under the
#: quadratic Morison drag, which has no closed form, with these names given
#: :mod:`~iceimpact.solvers.search.dragged`'s functions instead (:func:`~iceimpact.compiled.
#: rebound`, :func:`~iceimpact.compiled.jit`; each name checked to be one the march reads).
#: Each takes ``integrated``, the structure's motion beyond its anchor: 0 for a closed form
#: (which needs none: :func:`_new_flight` and :func:`_failed` then do nothing),
#: the arrays of the Taylor steps (:func:`~iceimpact.solvers.search.dragged.new_steps`) under
#: the drag. numba cannot cache a kernel that takes functions as arguments (its signature holds
#: the functions: a miss in every process), so they are given by name.
STRUCTURE_CALLEES = {
    "flight_root": "the flight's root search (the first contact, or the frontier reached)",
    "_flight_constants": "the constants of the structure's closed form from the anchor",
    "_flight_sample": "the state at a sample time of the flight",
    "_structure_accel": "the structure's acceleration (the contact force after an impact)",
    "_new_flight": "a flight starts at the contact: the structure's motion made afresh there",
    "_failed": "whether the structure's motion could not be made (the march hands back)",
}

#: :data:`STRUCTURE_CALLEES` under the quadratic Morison drag, as Python: the flight search on
#: :mod:`.dragged`'s gap (:data:`~iceimpact.solvers.search.dragged.PYTHON_ROOT`), and its
#: sample, acceleration and steps
DRAGGED_CALLEES = {"flight_root": dragged.PYTHON_ROOT, "_flight_constants": _flight_constants,
                   **dragged.MARCH_CALLEES}
#: :data:`STRUCTURE_CALLEES` for the modal structure, as Python: the flight search on the sum of
#: the modes (:data:`~iceimpact.solvers.search.modal_search.PYTHON_ROOT`), and the modal state
#: at an impact and at the samples
MODAL_CALLEES = {"flight_root": modal_search.PYTHON_ROOT, **modal_search.MARCH_CALLEES}


def _structure_callees(callees: dict[str, Any]) -> dict[str, Any]:
    """``callees``, checked to be exactly :data:`STRUCTURE_CALLEES`' names (KeyError
    otherwise): a structure gives the march every one of them, and nothing else."""
    if set(callees) != set(STRUCTURE_CALLEES):
        raise KeyError(f"the march's structure callees are {sorted(STRUCTURE_CALLEES)}, not "
                       f"{sorted(callees)}")
    return callees


def bounce_march(F, N, P, times, xs, vs, zs, ws, targets, values, impacts, integrated):
    """March bounces from the flight in F (see :data:`FLOATS`) until something else comes.

    A march to ``F[FLOATS.T_END]`` (``N[INTS.N_TIMES]`` = 0) adds each impact's impulse to
    ``F[FLOATS.IMPULSE]`` in the order :meth:`EventMarch.march` adds them. A sampled march
    (``times``, the first ``N[INTS.N_TIMES]`` of them, from sample ``N[INTS.SAMPLE]`` on)
    writes what :meth:`EventSolver.sample` would: the states at the samples of each flight it
    ends (``xs``, ``vs``, ``zs``, ``ws``: the flight search's closed forms, the same floats as
    the sampler's array closed forms, ``Flight.state_array``), per impact its sample and
    impulse (``targets``, ``values``), and runs each sample interval's impact budget. Every
    impact goes to ``impacts`` (t, x, v-, w-, v+, w+, impulse, e). ``N[INTS.STATUS]`` says why
    it returned.

    ``integrated`` is the structure's motion beyond its anchor, which the functions of
    :data:`STRUCTURE_CALLEES` take: 0 for the closed forms, the Taylor steps' arrays under the
    quadratic Morison drag (:data:`DRAGGED_MARCH`, :func:`dragged_kernel`), the modes' arrays
    for the modal structure (:data:`MODAL_MARCH`, :func:`modal_kernel`)."""
    offset, mass, damping = P[PARAMS.OFFSET], P[PARAMS.MASS], P[PARAMS.DAMPING]
    stiffness, omega2 = P[PARAMS.STIFFNESS], P[PARAMS.OMEGA2]
    sigma, omega, u, coef = P[PARAMS.SIGMA], P[PARAMS.OMEGA], P[PARAMS.U], P[PARAMS.COEF]
    quadratic = 1 if P[PARAMS.QUADRATIC] != 0.0 else 0
    structure_mass, ice_mass = P[PARAMS.STRUCTURE_MASS], P[PARAMS.ICE_MASS]
    reduced_mass, omega_n, e = P[PARAMS.REDUCED_MASS], P[PARAMS.OMEGA_N], P[PARAMS.E]
    chatter, budget = P[PARAMS.CHATTER], P[PARAMS.BUDGET]
    follow_zeno = P[PARAMS.FOLLOW_ZENO] != 0.0
    time_resolution = P[PARAMS.TIME_RESOLUTION]
    gap_relative, gap_absolute = P[PARAMS.GAP_RELATIVE], P[PARAMS.GAP_ABSOLUTE]
    max_impacts = int(P[PARAMS.MAX_IMPACTS])
    s_slow, s_fast, form = P[PARAMS.S_SLOW], P[PARAMS.S_FAST], int(P[PARAMS.FORM])
    max_step = P[PARAMS.MAX_STEP]
    n_times = N[INTS.N_TIMES]
    while True:
        t0, x0, v0 = F[FLOATS.T0], F[FLOATS.X0], F[FLOATS.V0]
        z0, w0 = F[FLOATS.Z0], F[FLOATS.W0]
        horizon = (times[n_times - 1] if n_times > 0 else F[FLOATS.T_END]) - t0
        # the flight's constants (Flight.kernel_constants' order)
        sk = _flight_constants(form, offset, sigma, omega, omega2, s_slow, s_fast, x0, v0,
                               integrated)
        if quadratic:
            rate, w0_c, r0 = quadratic_flight_constants(coef, w0, u)
        else:
            rate, w0_c, r0 = linear_flight_constants(coef, w0, u)
        if F[FLOATS.ROOT_AT] != F[FLOATS.ROOT_AT]:  # the search goes on
            (outcome, a, root, iterations, creep, probed_at, pf, pdf, pd2, pbound, pjerk, dx, v,
             dz, w) = flight_root(horizon, F[FLOATS.A], N[INTS.ITERATIONS], N[INTS.CREEP],
                              F[FLOATS.PROBED_AT], F[FLOATS.PF], F[FLOATS.PDF], F[FLOATS.PD2],
                              F[FLOATS.PBOUND], F[FLOATS.PJERK], F[FLOATS.TIME_EPS], x0 - z0,
                              x0, z0, offset, mass, damping, stiffness, omega2, sigma, s_slow,
                              s_fast, form, sk[0], sk[1], sk[2], sk[3], sk[4], sk[5], sk[6],
                              sk[7], rate, w0_c, r0, u, coef, quadratic, max_step, integrated)
            if a != a or (outcome == ROOT and root != root) or _failed(integrated):
                N[INTS.STATUS] = EVENT  # (FlightSearch hands this search to RootSearch)
                return
            F[FLOATS.A], N[INTS.ITERATIONS], N[INTS.CREEP] = a, iterations, creep
            F[FLOATS.PROBED_AT], F[FLOATS.PF], F[FLOATS.PDF] = probed_at, pf, pdf
            F[FLOATS.PD2], F[FLOATS.PBOUND], F[FLOATS.PJERK] = pd2, pbound, pjerk
            if outcome == GENERIC:
                N[INTS.STATUS] = EVENT
                return
            if outcome != ROOT:
                N[INTS.STATUS] = END
                return
            F[FLOATS.ROOT_AT], F[FLOATS.RDX], F[FLOATS.RV] = root, dx, v
            F[FLOATS.RDZ], F[FLOATS.RW] = dz, w
        tau = F[FLOATS.ROOT_AT]
        if tau > horizon:
            N[INTS.STATUS] = END
            return
        j = 0
        if n_times > 0:  # the first sample at or after the event (EventSolver._sample's test)
            i = N[INTS.SAMPLE]
            if times[i] - t0 >= tau:
                j = i
            elif i + 1 == n_times or times[i + 1] - t0 >= tau:
                j = i + 1
            else:
                j = first_sample_after(times, i + 2, t0, tau)
        # the flight's end at the contact: ContactRules.impact_at_contact, parting only
        t = t0 + tau
        x, v, w = x0 + F[FLOATS.RDX], F[FLOATS.RV], F[FLOATS.RW]
        closing = w - v
        if not closing > 0.0 or rounding_closing(closing, x, v, w, u, omega_n) or e == 0.0:
            N[INTS.STATUS] = EVENT
            return
        v_plus, w_plus = impact(v, w, structure_mass, ice_mass, e)
        a_x = _structure_accel(t, tau, x, v, v_plus, offset, mass, damping, stiffness, u,
                               integrated)
        lam = contact_force(a_x, _ice_accel(w_plus, u, coef, quadratic)[0], structure_mass,
                            ice_mass)
        close, _ = bounce_closure(t, x, e, lam, v_plus - w_plus, reduced_mass, chatter,
                                  follow_zeno, budget, time_resolution, gap_relative,
                                  gap_absolute)
        closing = w_plus - v_plus
        if close or not (closing < 0.0
                         and not rounding_closing(closing, x, v_plus, w_plus, u, omega_n)):
            N[INTS.STATUS] = EVENT
            return
        limit = N[INTS.LIMIT]
        if n_times > 0 and N[INTS.INTERVAL] != j:
            limit = N[INTS.COUNT] + max_impacts
        if N[INTS.COUNT] >= limit:  # (Solver._record refuses it)
            N[INTS.STATUS] = EVENT
            return
        if N[INTS.N_IMPACTS] == impacts.shape[0] or N[INTS.N_TARGETS] == targets.shape[0]:
            N[INTS.STATUS] = FULL
            return
        # the impact: recorded, its impulse where the march adds it
        impulse = impact_impulse(v, v_plus, structure_mass)
        k = N[INTS.N_IMPACTS]
        impacts[k, 0], impacts[k, 1], impacts[k, 2], impacts[k, 3] = t, x, v, w
        impacts[k, 4], impacts[k, 5], impacts[k, 6], impacts[k, 7] = v_plus, w_plus, impulse, e
        N[INTS.N_IMPACTS] = k + 1
        N[INTS.COUNT] += 1
        if n_times > 0:
            for k in range(N[INTS.SAMPLE], j):  # the flight's samples
                xs[k], vs[k], zs[k], ws[k] = _flight_sample(k, times[k] - t0, x0, v0, z0, w0,
                                                            form, sk, rate, w0_c, r0, quadratic,
                                                            integrated)
            k = N[INTS.N_TARGETS]
            targets[k], values[k] = j, 0.0 + impulse
            N[INTS.N_TARGETS] = k + 1
            if N[INTS.INTERVAL] != j:  # (Solver.begin_step of sample j's interval)
                N[INTS.INTERVAL], N[INTS.LIMIT], F[FLOATS.STEP_START] = j, limit, times[j - 1]
            N[INTS.SAMPLE] = j
        else:
            F[FLOATS.IMPULSE] = (F[FLOATS.IMPULSE] + 0.0) + (0.0 + impulse)
        # the next flight, from the contact, its search from 0 (Flight, FlightSearch)
        x0, v0 = _new_flight(integrated, t, x, v_plus)
        F[FLOATS.T0], F[FLOATS.X0], F[FLOATS.V0] = t, x0, v0
        F[FLOATS.Z0], F[FLOATS.W0], F[FLOATS.START] = x0, w_plus, 0.0
        F[FLOATS.TIME_EPS] = _time_eps(t)
        F[FLOATS.A], F[FLOATS.ROOT_AT] = 0.0, math.nan
        F[FLOATS.PROBED_AT] = F[FLOATS.PF] = F[FLOATS.PDF] = math.nan
        F[FLOATS.PD2] = F[FLOATS.PBOUND] = F[FLOATS.PJERK] = math.nan
        N[INTS.ITERATIONS], N[INTS.CREEP] = 0, 0
        N[INTS.EVENTS] += 1
        if (n_times == 0 and N[INTS.STOP_AT_EVENT] != 0
                and F[FLOATS.T_START] < t < F[FLOATS.T_END]):
            N[INTS.STATUS] = STOPPED
            return


#: :func:`bounce_march` for the structure under the quadratic Morison drag, run as Python (the
#: tests' reference for the compiled one): :data:`STRUCTURE_CALLEES` given
#: :data:`DRAGGED_CALLEES`
DRAGGED_MARCH = rebound(bounce_march, **_structure_callees(DRAGGED_CALLEES))
#: :func:`bounce_march` for the modal structure, run as Python (the tests' reference):
#: :data:`STRUCTURE_CALLEES` given :data:`MODAL_CALLEES`
MODAL_MARCH = rebound(bounce_march, **_structure_callees(MODAL_CALLEES))

_RULES: dict[str, Any] = {}


def _compiled_rules(numba: Any) -> dict[str, Any]:
    """The compiled rules the march calls (either structure's: the same functions, compiled
    once), by the names it calls them."""
    if not _RULES:
        f8, i8 = numba.float64, numba.int64
        _RULES.update({
            "linear_flight_constants": jit(numba, (f8,) * 3, linear_flight_constants),
            "quadratic_flight_constants": jit(numba, (f8,) * 3, quadratic_flight_constants),
            "rounding_closing": jit(numba, (f8,) * 6, rounding_closing),
            "impact": jit(numba, (f8,) * 5, impact),
            "impact_impulse": jit(numba, (f8,) * 3, impact_impulse),
            "contact_force": jit(numba, (f8,) * 4, contact_force),
            "bounce_closure": jit(numba, (f8,) * 7 + (numba.boolean,) + (f8,) * 4,
                                  bounce_closure),
            "first_sample_after": jit(numba, (f8[::1], i8, f8, f8), first_sample_after),
            "_time_eps": jit(numba, (f8,), _time_eps),
        })
    return _RULES


@functools.cache
def _response_constants(numba: Any) -> Any:
    """``response_constants`` compiled, once (the closed forms' flights and the modes' use it)."""
    f8 = numba.float64
    return jit(numba, (numba.int64,) + (f8,) * 8, response_constants,
               under_constants=jit(numba, (f8,) * 6, under_constants))


def _sdof_constants(numba: Any, integrated: Any = None) -> Any:
    """:func:`_flight_constants` compiled, the structure's motion of type ``integrated`` (an
    integer, unused, for the closed forms)."""
    f8 = numba.float64
    return jit(numba, (numba.int64,) + (f8,) * 8 + (integrated or numba.int64,),
               _flight_constants, response_constants=_response_constants(numba))


def _march_signature(numba: Any, integrated: Any) -> tuple:
    """The argument types of :func:`bounce_march`, the structure's motion of type
    ``integrated``."""
    f8, i8 = numba.float64, numba.int64
    array1, array2 = f8[::1], f8[:, ::1]
    return (array1, i8[::1], array1, array1, array1, array1, array1, array1, i8[::1], array1,
            array2, integrated)


def _compile(numba: Any) -> Any:
    """:func:`bounce_march` compiled by numba on the closed forms: :data:`STRUCTURE_CALLEES`
    the compiled forms of this module's and the flight search's functions."""
    f8, i8 = numba.float64, numba.int64
    search = flight_search.compiled_callees(numba)
    k8 = numba.types.UniTuple(f8, 8)
    structure = _structure_callees({
        "flight_root": search["flight_root"],
        "_flight_sample": jit(numba, (i8,) + (f8,) * 5 + (i8, k8, f8, f8, f8, i8, i8),
                              _flight_sample,
                              _motion=search["_motion"]),
        "_flight_constants": _sdof_constants(numba),
        "_structure_accel": jit(numba, (f8,) * 10 + (i8,), _structure_accel),
        "_new_flight": jit(numba, (i8, f8, f8, f8), _new_flight),
        "_failed": jit(numba, (i8,), _failed),
    })
    kernel = jit(numba, _march_signature(numba, i8), bounce_march,
                 _ice_accel=search["_ice_accel"], **structure, **_compiled_rules(numba))
    return entry_point(kernel)


#: numba's compiled :func:`bounce_march`, or None (numba absent, ``ICEIMPACT_PURE`` set, or the
#: flight search not compiled): the Python march runs alone
COMPILED = (compile_or_none("the march of bounces", _compile)
            if flight_search.COMPILED is not None else None)


def _compile_dragged(numba: Any) -> Any:
    """:func:`bounce_march` compiled for the structure under the quadratic Morison drag:
    :data:`STRUCTURE_CALLEES` the compiled forms of :data:`DRAGGED_CALLEES`."""
    search = flight_search.compiled_callees(numba)
    structure = _structure_callees({
        **dragged.compiled_callees(numba, taylor.KERNELS.dispatchers, search),
        "_flight_constants": _sdof_constants(numba, dragged.steps_type(numba))})
    kernel = jit(numba, _march_signature(numba, dragged.steps_type(numba)), bounce_march,
                 _ice_accel=search["_ice_accel"], **structure, **_compiled_rules(numba))
    return entry_point(kernel)


def _compile_modal(numba: Any) -> Any:
    """:func:`bounce_march` compiled for the modal structure: :data:`STRUCTURE_CALLEES` the
    compiled forms of :data:`MODAL_CALLEES`."""
    search = flight_search.compiled_callees(numba)
    rules = _compiled_rules(numba)
    structure = _structure_callees(modal_search.march_callees(numba,
                                                              _response_constants(numba)))
    kernel = jit(numba, _march_signature(numba, modal_search.modes_type(numba)), bounce_march,
                 borrows=True, _ice_accel=search["_ice_accel"], **structure, **rules)
    return entry_point(kernel)


@functools.cache
def modal_kernel() -> Any:
    """The compiled march for the modal structure, compiled at its first use, or None (not
    compiled: its flights are Python's)."""
    if COMPILED is None or modal_search.COMPILED is None:
        return None
    return compile_or_none("the march of bounces on the modes", _compile_modal)


@functools.cache
def dragged_kernel() -> Any:
    """The compiled march under the quadratic Morison drag, compiled at its first use (most
    scenes never ask), or None (not compiled: the Python march runs)."""
    if COMPILED is None or taylor.KERNELS is None:
        return None
    return compile_or_none("the march of bounces under the quadratic Morison drag",
                           _compile_dragged)


class BounceMarch:
    """An :class:`EventSolver`'s compiled march of bounces: the arrays it hands the kernel, and
    the way from the solver's objects to them and back (the flight to go on with, the impacts,
    the sampler's records). ``kernel``: :func:`bounce_march`, compiled (or, in tests, as
    Python: :data:`DRAGGED_MARCH` for the quadratic Morison drag), for the solver's flights
    (:class:`Flight`, or :class:`DraggedFlight` and its Taylor steps in arrays). It reads and
    writes of the solver only what :class:`~.context.BounceHost` names."""

    def __init__(self, solver: BounceHost, kernel: Any = None):
        self.solver = solver
        self.context = solver.context
        self.flight_type = self.context.flight_cls
        self.dragged = self.flight_type is DraggedFlight
        if kernel is None:
            kernel = dragged_kernel() if self.dragged else COMPILED
        self.kernel = kernel
        #: the dragged flight whose Taylor steps the arrays hold (0: a closed form's, none)
        self.integrated: Any = 0
        self._steps_for: Any = None
        self.F = np.zeros(len(FLOATS))
        self.N = np.zeros(len(INTS), dtype=np.int64)
        self.P = np.zeros(len(PARAMS))
        self.no_times = np.zeros(1)
        self._params_for: tuple | None = None

    # the records, made at the first march (a solver that never meets a bounce makes none)
    @functools.cached_property
    def targets(self) -> np.ndarray:
        return np.zeros(CAPACITY, dtype=np.int64)

    @functools.cached_property
    def values(self) -> np.ndarray:
        return np.zeros(CAPACITY)

    @functools.cached_property
    def impacts(self) -> np.ndarray:
        return np.zeros((CAPACITY, 8))

    def takes(self, seg: Any) -> bool:
        """The kernel can go on from this segment: a flight of the built-in structure in any
        damping regime (its closed form, or its Taylor steps under the quadratic Morison drag),
        its search not handed to RootSearch, and no Zeno tail running."""
        if type(seg) is Flight:
            return (seg.kernel_constants is not None and not seg.search.handed_back
                    and self.solver.zeno_end is None and not self.dragged)
        return (type(seg) is DraggedFlight and self.dragged and self.kernel is not None
                and not seg.handed_back and self.solver.zeno_end is None)

    def _structure(self, seg: Any) -> tuple[Any, dict[str, float]]:
        """What identifies the structure of ``seg``'s flight, and its fields of :data:`PARAMS`
        (OFFSET to FORM): its oscillator's."""
        osc = seg.osc
        return osc, oscillator_fields(osc.search_constants, osc.omega)

    def _params(self, seg: Any) -> None:
        """The scene's constants into P, each by its field (:data:`PARAMS`), unless they are
        those already there."""
        context = self.context
        rules = context.rules
        e = self.solver.e
        structure, fields_of_structure = self._structure(seg)
        key = (structure, seg.u, e, rules.follow_zeno, context.max_impacts)
        if key == self._params_for:
            return
        self._params_for = key
        drag = context.drag
        coef, quadratic = drag.law_constants
        gap_relative, gap_absolute = rules.gap_noise
        self.P[:] = type(PARAMS)(
            **fields_of_structure, U=seg.u, COEF=coef, QUADRATIC=float(quadratic),
            STRUCTURE_MASS=rules.m, ICE_MASS=rules.M, REDUCED_MASS=rules.mu,
            OMEGA_N=rules.omega_n, E=e, CHATTER=rules.chatter_time,
            FOLLOW_ZENO=float(rules.follow_zeno), BUDGET=rules.budget_bounce(e),
            TIME_RESOLUTION=rules.time_resolution, GAP_RELATIVE=gap_relative,
            GAP_ABSOLUTE=gap_absolute, MAX_IMPACTS=float(context.max_impacts),
            MAX_STEP=seg.search.max_step)

    def _steps(self, seg: Any) -> None:
        """A dragged flight's Taylor steps into the arrays: those made there already if the
        kernel ended on this flight, else none yet (the kernel makes them from its anchor, the
        same steps as the flight's own)."""
        integrated = self.integrated
        if isinstance(integrated, int):
            integrated = self.integrated = dragged.new_steps(
                seg.taylor, self.context.dragged_structure.omega2)
        q, ints = integrated[0], integrated[1]
        q[dragged.FLIGHT.U] = seg.u
        if seg is not self._steps_for:
            q[dragged.FLIGHT.X0], q[dragged.FLIGHT.V0] = seg.x0, seg.v0
            ints[dragged.COUNTERS.COUNT] = ints[dragged.COUNTERS.FAILED] = 0

    def _root_state(self, seg: Any, root: float) -> tuple:
        """(tau, x - x0, v, z - z0, w) at the root its search found."""
        if self.dragged:
            return (root, *seg._structure(root), *seg._z_motion(root))
        last = seg._last
        return last if last[0] == root else (root, *seg._motion(root)[1:])

    def _integrated_of(self, seg: Any) -> None:
        """The structure's motion beyond the anchor of ``seg`` into ``integrated``."""
        if self.dragged:
            self._steps(seg)

    def _load(self, seg: Any) -> None:
        """The flight ``seg`` and its search into F and N."""
        search = seg.search
        probed = search._probed or flight_search._UNPROBED
        root = search.root
        root_state = (math.nan,) * 5 if root is None else self._root_state(seg, root)
        self._integrated_of(seg)
        self.F[:FLOATS.RW + 1] = (seg.t0, seg.x0, seg.v0, seg.z0, seg.w0, seg.start,
                                 search.time_eps, search.a, search._probed_at, *probed,
                                 *root_state)
        N = self.N
        N[INTS.ITERATIONS], N[INTS.CREEP] = search.iterations, search.creep
        N[INTS.N_IMPACTS] = N[INTS.N_TARGETS] = N[INTS.EVENTS] = 0

    def _flight(self, seg: Any, F: list[float], N: list[int]) -> Any:
        """The flight the kernel ended on, as the solver's segment: ``seg`` itself if no event
        was taken, else a new one; its search where the kernel left it."""
        solver = self.solver
        if N[INTS.EVENTS]:
            seg = self._new_segment(F, seg.u)
            solver.seg = seg
            solver.tau = 0.0
        self._integrated_to(seg, N)
        search = seg.search
        search.a, search.iterations = F[FLOATS.A], N[INTS.ITERATIONS]
        search.creep = N[INTS.CREEP]
        search._probed_at = F[FLOATS.PROBED_AT]
        search._probed = tuple(F[FLOATS.PF:FLOATS.PJERK + 1])
        root = F[FLOATS.ROOT_AT]
        if root == root:
            search.root = root
            seg.remember((root, F[FLOATS.RDX], F[FLOATS.RV], F[FLOATS.RDZ], F[FLOATS.RW]))
        return seg

    def _new_segment(self, F: list[float], u: float) -> Any:
        """The flight the kernel started last, as the solver's segment."""
        return self.flight_type(self.context, *F[FLOATS.T0:FLOATS.W0 + 1], u, F[FLOATS.START])

    def _integrated_to(self, seg: Any, N: list[int]) -> None:
        """What the kernel made of the structure's motion, to ``seg``: a dragged flight's Taylor
        steps are the arrays' (``seg``'s own where the kernel hands it back)."""
        if self.dragged:
            self._steps_for = seg
            if N[INTS.STATUS] == EVENT:  # (its search, or its steps, are Python's from here)
                seg.handed_back = True

    def _impacts(self, n: int) -> None:
        """The kernel's n impacts into the solver's count and list (as Solver._record)."""
        if n:
            self.solver.record_rows(self.impacts[:n])

    def _begin(self) -> Any:
        """The solver's current flight, the scene's constants, the impact count and the budget
        into the arrays; the flight."""
        solver = self.solver
        seg = solver.seg
        self._params(seg)
        self._load(seg)
        limit = solver.impact_limit
        self.N[INTS.COUNT], self.N[INTS.LIMIT] = (solver.impact_count,
                                                  limit if limit < NO_LIMIT else NO_LIMIT)
        return seg

    def _run(self, times: np.ndarray, xs: np.ndarray, vs: np.ndarray, zs: np.ndarray,
             ws: np.ndarray) -> None:
        """One call of the kernel. A Taylor step the compiled kernels hand back
        (:class:`HandBack`, the dragged structure's) ends it as an event Python takes: the
        impacts before it are counted in N, the flight it was searching is as it started."""
        try:
            self.kernel(self.F, self.N, self.P, times, xs, vs, zs, ws, self.targets, self.values,
                        self.impacts, self.integrated)
        except HandBack:
            self.N[INTS.STATUS] = EVENT

    def march(self, t_end: float, stop_at_event: bool, t_start: float,
              impulse: float) -> tuple[float, float | None]:
        """From the solver's current flight, the bounces up to ``t_end`` (EventMarch.march's
        loop, ``impulse`` its sum so far); returns the sum, and the time of the impact that
        ended the march with ``stop_at_event`` (None: the march goes on in Python)."""
        seg = self._begin()
        F, N = self.F, self.N
        F[FLOATS.IMPULSE], F[FLOATS.T_END], F[FLOATS.T_START] = impulse, t_end, t_start
        N[INTS.STOP_AT_EVENT], N[INTS.N_TIMES] = 1 if stop_at_event else 0, 0
        while True:
            no = self.no_times
            self._run(no, no, no, no, no)
            status = int(N[INTS.STATUS])
            self._impacts(int(N[INTS.N_IMPACTS]))
            if status != FULL:
                break
            N[INTS.N_IMPACTS] = 0
        f_values, n_values = F.tolist(), N.tolist()
        self._flight(seg, f_values, n_values)
        impulse = f_values[FLOATS.IMPULSE]
        return impulse, (f_values[FLOATS.T0] if status == STOPPED else None)

    def sample(self, times: np.ndarray, i: int, interval: int, out: Any, targets: Any,
               values: Any) -> tuple[int, int]:
        """From the solver's current flight and sample i, the bounces of a sampled march
        (EventSolver._sample's loop, ``interval`` the sample interval whose budget runs): the
        states at the samples of the flights it ends to ``out`` (:class:`Samples`), the
        impulses to ``targets`` and ``values``; returns the sample and the interval the march
        stands at."""
        solver = self.solver
        seg = self._begin()
        F, N = self.F, self.N
        F[FLOATS.STEP_START] = solver.step_start
        N[INTS.SAMPLE], N[INTS.INTERVAL] = i, interval
        N[INTS.STOP_AT_EVENT], N[INTS.N_TIMES] = 0, len(times)
        while True:
            self._run(times, out.x, out.v, out.z, out.w)
            self._impacts(int(N[INTS.N_IMPACTS]))
            n_targets = int(N[INTS.N_TARGETS])
            if n_targets:
                targets.frombytes(self.targets[:n_targets].tobytes())
                values.frombytes(self.values[:n_targets].tobytes())
            if int(N[INTS.STATUS]) != FULL:
                break
            N[INTS.N_IMPACTS] = N[INTS.N_TARGETS] = 0
        f_values, n_values = F.tolist(), N.tolist()
        self._flight(seg, f_values, n_values)
        limit = n_values[INTS.LIMIT]
        solver.impact_limit = limit if limit < NO_LIMIT else math.inf
        solver.step_start = f_values[FLOATS.STEP_START]
        return n_values[INTS.SAMPLE], n_values[INTS.INTERVAL]
