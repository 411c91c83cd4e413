"""An independent reference for the modal structure (structure.model = 3): the ice against N modes
seen at the contact point, integrated impact by impact with scipy ``solve_ivp`` (DOP853, rtol
1e-12) and dense event location.

It shares no code with the solvers or the physics of :mod:`iceimpact` (only the :class:`Scene`'s
fields are read): the modal equations, the drag, the impact law, the riding phase and its contact
force are written out here from the model page:

    m_k q_k'' + c_k q_k' + k_k q_k = phi_k F + L_k,   c_k = 2 zeta_k w_k m_k, k_k = m_k w_k^2
    x = sum phi_k q_k,   M z'' = D(z') - F,   gap g = x - z >= 0

In flight (F = 0) the state is ``(q, q', g, g')``: the gap is integrated itself rather than taken
as the difference of two positions, so that it is accurate relative to its own size where the
bodies part with equal velocities (g = g' = 0) and a spurious root next to the start cannot
appear. An impact is the gap's root with the ice approaching (event direction -1); Newton's law
with the effective mass ``1 / m_eff = sum phi_k^2 / m_k`` gives the impulse J on the structure,
and each mode's velocity jumps by ``phi_k J / m_k``. A plastic impact (e = 0, or one closing a
chatter sequence, :func:`simulate`'s ``chatter_speed``) starts riding if the contact force there
is positive, else the bodies fly apart with equal velocities. Riding (z = x) has the state
``(q, q')`` and ends at the root of the contact force ``lam = m_eff (D + M S) / (M + m_eff)``
(event direction -1), ``S = sum phi_k (c_k q_k' + k_k q_k - L_k) / m_k``.

Valid for a constant flow, mode loads held or given as functions of time, and scenes whose
bounces are well separated: a grazing contact (a double root of the gap inside one step) can
be missed, and a chatter sequence with e > 0 is either closed at ``chatter_speed`` or stopped
by :class:`ChatterError` after ``max_impacts``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from iceimpact import Scene

RTOL = 1e-12
#: absolute tolerance relative to the scene's position and velocity scales
ATOL_SCALE = 1e-14
#: the first step of a flight where the bodies part with equal velocities, in periods of the
#: fastest mode
PARTING_STEP = 1e-9
#: a bounce shorter than this, in periods of the fastest mode, ends a chatter sequence
CHATTER = 1e-10


class ChatterError(RuntimeError):
    """A chatter sequence (impacts accumulating with e > 0) the reference does not follow."""


class ReferenceImpact(NamedTuple):
    """One impact. Velocities of the contact point (v) and of the ice (w), m/s; J in N.s."""

    t: float
    impulse: float
    v_minus: float
    w_minus: float
    v_plus: float
    w_plus: float
    x: float            # contact position, m
    restitution: float  # e applied: 0 for a plastic impact closing a chatter sequence


@dataclass
class ReferenceRun:
    """A reference run: its impacts, riding phases and the states at the requested times."""

    impacts: list[ReferenceImpact] = field(default_factory=list)
    #: (start, end) of each riding phase, s; end is math.inf for one still going at t_end
    riding: list[tuple[float, float]] = field(default_factory=list)
    #: the requested sample times and, at each, the modal displacements and velocities (rows),
    #: the contact point (x, v), the ice (z, w) and whether the ice rides
    t: np.ndarray = field(default_factory=lambda: np.empty(0))
    q: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    qd: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    x: np.ndarray = field(default_factory=lambda: np.empty(0))
    v: np.ndarray = field(default_factory=lambda: np.empty(0))
    z: np.ndarray = field(default_factory=lambda: np.empty(0))
    w: np.ndarray = field(default_factory=lambda: np.empty(0))
    ride: np.ndarray = field(default_factory=lambda: np.empty(0, bool))
    #: the state at t_end: q, q', z, w and whether the ice rides
    final: tuple[np.ndarray, np.ndarray, float, float, bool] | None = None
    nfev: int = 0


class _Model:
    """The scene's constants and right-hand sides, written out from the model page."""

    def __init__(self, scene: Scene):
        if scene.structure_Ca or scene.structure_Cd:
            raise NotImplementedError("Morison loads on the modal structure")
        modes = [tuple(getattr(scene, f"structure_mode{k}_{name}")
                       for name in ("f", "zeta", "m", "phi", "q0", "v0"))
                 for k in range(1, scene.structure_modes + 1)]
        f, zeta, m, phi, q0, v0 = (np.array(col, float) for col in zip(*modes, strict=True))
        omega = 2.0 * np.pi * f
        self.n = len(modes)
        self.m, self.phi, self.q0, self.v0 = m, phi, q0, v0
        self.c = 2.0 * zeta * omega * m
        self.k = m * omega * omega
        self.load = np.array([getattr(scene, f"structure_mode{k}_load")
                              for k in range(1, self.n + 1)], float)
        #: the loads as a function of time (N, one per mode), or None: held at ``load``
        self.loads: Any = None
        self.m_eff = 1.0 / float(np.sum(phi * phi / m))
        self.M, self.e, self.u = scene.ice_M, scene.impact_e, scene.flow_u
        big_b = 0.5 * scene.fluid_rho * scene.ice_Cd * scene.ice_A
        self.quadratic = scene.drag_model == 2
        self.drag_constant = big_b if self.quadratic else big_b * scene.drag_v_lin
        self.z0, self.w0 = scene.ice_z0, scene.ice_v0
        # scales of the tolerances: the fastest mode's period and the largest speed
        self.period = float(2.0 * np.pi / np.max(omega))
        speed = max(abs(self.u), abs(self.w0), float(np.max(np.abs(phi * v0))), 1e-3)
        length = max(speed / float(np.min(omega)), abs(self.z0),
                     float(np.max(np.abs(phi * q0))))
        n = self.n
        self.atol_flight = np.concatenate((np.full(n, ATOL_SCALE * length), np.full(
            n, ATOL_SCALE * speed), [ATOL_SCALE * length, ATOL_SCALE * speed]))
        self.atol_riding = self.atol_flight[:2 * n]

    def drag(self, w: float) -> float:
        """The drag on the ice at speed w, N (positive towards the structure)."""
        r = self.u - w
        return self.drag_constant * (abs(r) * r if self.quadratic else r)

    def free_accelerations(self, q: np.ndarray, qd: np.ndarray, t: float = 0.0) -> np.ndarray:
        """q_k'' of the modes without contact force at time t."""
        load = self.load if self.loads is None else np.asarray(self.loads(t), float)
        return (load - self.c * qd - self.k * q) / self.m

    def contact_force(self, q: np.ndarray, qd: np.ndarray, t: float = 0.0) -> float:
        """lam, the force on the structure while the ice rides on the contact point, N."""
        s = -float(np.dot(self.phi, self.free_accelerations(q, qd, t)))
        return self.m_eff * (self.drag(float(np.dot(self.phi, qd))) + self.M * s) / (
            self.M + self.m_eff)

    def flight(self, t: float, y: np.ndarray) -> np.ndarray:
        """(q, q', g, g')' in flight: g = x - z, g' = v - w."""
        n = self.n
        q, qd, rel = y[:n], y[n:2 * n], y[2 * n + 1]
        qdd = self.free_accelerations(q, qd, t)
        w = float(np.dot(self.phi, qd)) - rel
        gap_acceleration = float(np.dot(self.phi, qdd)) - self.drag(w) / self.M
        return np.concatenate((qd, qdd, [rel, gap_acceleration]))

    def riding(self, t: float, y: np.ndarray) -> np.ndarray:
        """(q, q')' while the ice rides on the contact point (the force lam on the structure)."""
        n = self.n
        q, qd = y[:n], y[n:]
        lam = self.contact_force(q, qd, t)
        return np.concatenate((qd, self.free_accelerations(q, qd, t) + self.phi * lam / self.m))


def simulate(scene: Scene | Mapping[str, Any], t_end: float,
             sample_times: Sequence[float] | np.ndarray | None = None,
             max_impacts: int = 2000, chatter_speed: float = 0.0,
             chatter: float = CHATTER, rtol: float = RTOL,
             loads: Any = None) -> ReferenceRun:
    """Simulate ``scene`` (a Scene or its keyword arguments) from 0 to ``t_end`` (s).

    ``loads``, if given, is the modes' generalized loads as a function of time (t -> one load
    per mode, N), in place of the scene's held structure.mode<k>.load.

    ``sample_times`` (increasing, in (0, t_end]) are the times whose states are returned. An
    impact is plastic, closing a chatter sequence, where its approach speed is at most
    ``chatter_speed`` (m/s) or the bounce after it would last less than ``chatter`` periods of
    the fastest mode (the rest of the sequence then lasts less than that over 1 - e); more than
    ``max_impacts`` impacts raise :class:`ChatterError`. ``rtol`` is solve_ivp's (the absolute
    tolerances scale with it).
    """
    if not isinstance(scene, Scene):
        scene = Scene(**scene)
    model = _Model(scene)
    model.loads = loads
    n = model.n
    times = np.asarray([] if sample_times is None else sample_times, float)
    run = ReferenceRun()
    rows: list[tuple] = []

    def gap(t: float, y: np.ndarray) -> float:
        return y[2 * n]

    gap.terminal, gap.direction = True, -1

    def force(t: float, y: np.ndarray) -> float:
        return model.contact_force(y[:n], y[n:], t)

    force.terminal, force.direction = True, -1

    def record(sol: Any, riding: bool, count: int) -> None:
        """The first ``count`` samples of a segment (its t_eval points)."""
        for j, ts in enumerate(sol.t[:count]):
            y = sol.y[:, j]
            q, qd = y[:n], y[n:2 * n]
            x, v = float(np.dot(model.phi, q)), float(np.dot(model.phi, qd))
            z, w = (x, v) if riding else (x - y[2 * n], v - y[2 * n + 1])
            rows.append((ts, q, qd, x, v, z, w, riding))

    t = 0.0
    q, qd = model.q0.copy(), model.v0.copy()
    g = float(np.dot(model.phi, q)) - model.z0
    rel = float(np.dot(model.phi, qd)) - model.w0
    riding = False
    first_step: float | None = None
    scale = rtol / RTOL  # the absolute tolerances follow the relative one
    mu = model.m_eff * model.M / (model.m_eff + model.M)  # the impact's reduced mass
    while t < t_end:
        start = t
        window = times[(times > t) & (times <= t_end)]
        # t_end is always evaluated, for the final state; it is a sample only if requested
        extra = not len(window) or window[-1] != t_end
        t_eval = np.append(window, t_end) if extra else window
        if riding:
            sol = solve_ivp(model.riding, (t, t_end), np.concatenate((q, qd)), method="DOP853",
                            rtol=rtol, atol=model.atol_riding * scale, events=force,
                            max_step=model.period / 8, t_eval=t_eval)
        else:
            sol = solve_ivp(model.flight, (t, t_end), np.concatenate((q, qd, [g, rel])),
                            method="DOP853", rtol=rtol, atol=model.atol_flight * scale, events=gap,
                            max_step=model.period / 8, first_step=first_step, t_eval=t_eval)
        run.nfev += sol.nfev
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed at t = {t}: {sol.message}")
        record(sol, riding, len(sol.t) - (extra and sol.status == 0))
        first_step = None
        if sol.status == 0:  # reached t_end
            y = sol.y[:, -1]
            q, qd = y[:n], y[n:2 * n]
            x, v = float(np.dot(model.phi, q)), float(np.dot(model.phi, qd))
            z, w = (x, v) if riding else (x - y[2 * n], v - y[2 * n + 1])
            run.final = (q, qd, z, w, riding)
            break
        t = float(sol.t_events[0][0])
        y = sol.y_events[0][0]
        q, qd = y[:n].copy(), y[n:2 * n].copy()
        if t <= start:  # a root at the start: a first step over a whole flight, or no gap at 0
            raise RuntimeError(f"an event at the start of a segment, t = {t}")
        if riding:  # the contact force reaches 0: the bodies part with equal velocities
            riding, g, rel = False, 0.0, 0.0
            first_step = PARTING_STEP * model.period
            run.riding[-1] = (run.riding[-1][0], t)
            continue
        v = float(np.dot(model.phi, qd))
        w = v - y[2 * n + 1]
        approach = max(w - v, 0.0)  # (a root found with the bodies parting is a touch)
        if len(run.impacts) >= max_impacts:
            raise ChatterError(f"more than {max_impacts} impacts by t = {t}")
        e = model.e if approach > chatter_speed else 0.0
        if e > 0.0:  # a bounce shorter than ``chatter`` ends a chatter sequence: plastic
            bounce = np.concatenate((q, qd + model.phi * (1.0 + e) * mu * approach / model.m,
                                     [0.0, e * approach]))
            closing = model.flight(t, bounce)[-1]
            if closing < 0.0 and 2.0 * e * approach / -closing < chatter * model.period:
                e = 0.0
        impulse = (1.0 + e) * mu * approach
        qd = qd + model.phi * impulse / model.m
        v_plus, w_plus = v + impulse / model.m_eff, w - impulse / model.M
        run.impacts.append(ReferenceImpact(t, impulse, v, w, v_plus, w_plus,
                                           float(np.dot(model.phi, q)), e))
        g, rel = 0.0, e * approach
        if e == 0.0 and model.contact_force(q, qd, t) > 0.0:
            riding = True
            run.riding.append((t, math.inf))
            continue
        # a short first step, so that the next bounce is not inside it: a tenth of the time
        # the gap takes to close again at its present deceleration; parting with equal
        # velocities, the gap may close again within microseconds (its rate of change of
        # acceleration against it), so the steps start tiny and grow tenfold each
        closing = model.flight(t, np.concatenate((q, qd, [g, rel])))[-1]
        if rel > 0.0 and closing < 0.0:
            first_step = min(0.1 * 2.0 * rel / -closing, model.period / 100)
        elif rel == 0.0:
            first_step = PARTING_STEP * model.period
    if rows:
        run.t = np.array([r[0] for r in rows])
        run.q = np.array([r[1] for r in rows])
        run.qd = np.array([r[2] for r in rows])
        run.x, run.v, run.z, run.w = (np.array([r[i] for r in rows]) for i in range(3, 7))
        run.ride = np.array([r[7] for r in rows], bool)
    return run


def reference_impacts(scene_kwargs: Scene | Mapping[str, Any], t_end: float,
                      **options: Any) -> list[ReferenceImpact]:
    """The impacts of the reference run of a scene (Scene keyword arguments) to ``t_end`` (s);
    ``options`` go to :func:`simulate`."""
    return simulate(scene_kwargs, t_end, **options).impacts


def sdof_as_mode(m: float, c: float, k: float, phi: float = 1.0, q0: float = 0.0,
                 v0: float = 0.0, index: int = 1) -> dict[str, float]:
    """The Scene keyword arguments of mode ``index`` equal to a single degree of freedom (m, c, k)
    at the contact point: f = sqrt(k/m) / (2 pi), zeta = c / (2 sqrt(k m)), modal mass m phi^2
    (with phi = 1, the mass m)."""
    return {f"structure_mode{index}_f": math.sqrt(k / m) / (2.0 * math.pi),
            f"structure_mode{index}_zeta": c / (2.0 * math.sqrt(k * m)),
            f"structure_mode{index}_m": m * phi * phi,
            f"structure_mode{index}_phi": phi,
            f"structure_mode{index}_q0": q0 / phi,
            f"structure_mode{index}_v0": v0 / phi}


# The scenes of the modal solver's tests ---------------------------------------------------------
#: mode 1 = the built-in structure (m = 1600 kg, c = 200 N.s/m, k = 1 MN/m), phi = 1
_BUILT_IN_MODE = sdof_as_mode(1600.0, 200.0, 1.0e6)
#: the second mode of the two-mode scenes: 11 Hz, zeta 0.02, 1600 kg, phi 0.6
_SECOND_MODE = {"structure_mode2_f": 11.0, "structure_mode2_zeta": 0.02,
                "structure_mode2_m": 1600.0, "structure_mode2_phi": 0.6}
_TWO_MODES = {"structure_model": 3, "structure_modes": 2, **_BUILT_IN_MODE}

#: Scene keyword arguments of the modal solver's tests. Over :data:`MODAL_T_END` each has well
#: separated impacts (tests/test_modal_reference.py checks the counts, the shortest flight and
#: the smallest approach speed):
#:
#: - ``two_underdamped``: the impacting scene of benchmarks/coupling.py (quadratic drag, u = 0.3
#:   m/s, M = 1200 kg, e = 0.7) on the built-in structure as mode 1 plus an 11 Hz mode; 13
#:   impacts to 2.5 s (a chatter sequence follows, closed at 2.63 s, then riding);
#: - ``overdamped_mode``: linear drag, u = 0.3 m/s, e = 0.8, mode 2 over-damped (6 Hz, zeta
#:   1.5, phi 0.5); 9 impacts to 5 s;
#: - ``sticking``: linear drag, u = 0.3 m/s, e = 0 on the two modes of ``two_underdamped``: 9
#:   plastic impacts and 6 riding phases that end by 4.5 s (one plastic impact parts the bodies
#:   and they meet again 1.4 ms later at 3.6e-6 m/s), a seventh riding from 3.96 s on;
#: - ``quadratic``: quadratic drag, u = 0.3 m/s, a 400 kg floe, e = 0.5, mode 2 with phi = -0.8;
#:   11 impacts to 1.2 s.
MODAL_SCENES: dict[str, dict[str, Any]] = {
    "two_underdamped": {"drag_model": 2, "flow_u": 0.3, "ice_M": 1200.0, "impact_e": 0.7,
                        **_TWO_MODES, **_SECOND_MODE},
    "overdamped_mode": {"drag_model": 1, "flow_u": 0.3, "impact_e": 0.8, **_TWO_MODES,
                        "structure_mode2_f": 6.0, "structure_mode2_zeta": 1.5,
                        "structure_mode2_m": 1600.0, "structure_mode2_phi": 0.5},
    "sticking": {"drag_model": 1, "flow_u": 0.3, "impact_e": 0.0, **_TWO_MODES,
                 **_SECOND_MODE},
    "quadratic": {"drag_model": 2, "flow_u": 0.3, "ice_M": 400.0, "impact_e": 0.5,
                  **_TWO_MODES, **_SECOND_MODE, "structure_mode2_phi": -0.8},
}
#: how long each scene is run, s
MODAL_T_END: dict[str, float] = {"two_underdamped": 2.5, "overdamped_mode": 5.0,
                                 "sticking": 4.5, "quadratic": 1.2}
