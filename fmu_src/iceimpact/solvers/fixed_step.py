"""Method 2, fixed-step: the article's own time-stepping scheme (Sections 4.1-4.2), for comparison.

On a fixed grid of step dt = ``solver.dt`` (s), anchored at the last impact:

- **Flight.** Both bodies follow their closed forms from the last impact, evaluated at the local
  time n dt (eq. 24: eq. 6-7 for the ice, eq. 9-10 for the structure, and the other damping
  regimes of :mod:`iceimpact.physics.structure`). With quadratic drag the ice is marched by
  explicit Euler instead (eq. 34-36: ``z_i = z_{i-1} + w_{i-1} dt``,
  ``w_i = w_{i-1} - (B/M) |w_{i-1} - u| (w_{i-1} - u) dt``); the structure keeps its closed form.
- **Impact test** at every grid point, when the bodies approach (``w > v``: eq. 13 presumes it;
  applying eq. 16-17 to separating bodies would throw them back together):

  * detection 1, the article's tolerance window (eq. 25-26):
    ``|x - z| <= Delta = 0.1 min(|v dt|, |w dt|)``. The window is narrower than the distance the
    gap closes in one step whenever the bodies move at different speeds, and of zero width while
    one of them is at rest, so it can be jumped over: the ice then passes through the structure.
  * detection 2, the sign change of the gap: ``x - z <= 0``.

  The impact applies eq. 16-17 to the velocities at that grid point; both closed forms restart
  there from the structure's position (eq. 18-24: ``z = x_k``), the local time resets to 0 and the
  global grid goes on.
- **Steady state** (eq. 27-29), only while the drag pushes (u >= 0: a contact cannot pull) and
  its position F / k below is within threshold (i):
  when (i) ``max(|z|, |x|) < 1e-4 m``, (ii) ``max(|w|, |v|) <
  1e-4 m/s`` and (iii) ``max(|z''|, |x''|) < 1e-4 m/s^2`` hold at a grid point, the bodies are
  pinned at ``x = z = F / k``, ``v = w = 0``, with ``F = b u`` (linear drag, eq. 28-29) or
  ``F = B u |u|`` (quadratic drag, the same balance), and stay there while u is unchanged; the
  structure then receives the constant contact force F. The accelerations of (iii) are backward
  differences of the marched velocities over the last step: they include the impacts, as the
  grid responses do. (The drag-law acceleration of a free floe, ``(b/M)(u - w)``, is about
  3e-3 m/s^2 in the article's scenes whenever (ii) holds, so (iii) could never be met with it.
  With u = 0.1 m/s the differences do not meet it either: the bodies chatter, meeting every few
  grid steps, and the article's e = 0.5 scenes are never pinned; see docs/explanation/accuracy.md.)

The communication step need not be a multiple of dt: impacts are tested on grid points only, and
the state at an off-grid time is the closed form there (a partial Euler step for the quadratic
ice), which does not touch the grid. Results therefore do not depend on the communication step.
Every Euler step, the partial one included, is held to eq. 36's stability limit,
(B/M) step |w - u| <= 2 (beyond it |w - u| grows at each step): a step that needs more is
refused, naming solver.dt. An impact at a grid point can give the ice a speed beyond it (a
light floe struck by a fast structure); the march refuses the grid's next step from there, and
a communication point before it is refused where its partial step is beyond the limit too.
A new flow speed (zero-order hold) starts a new grid at the time of the change; a pinned state is
then released and the scheme marches on from it.

The grid is evaluated in vectorised chunks (numpy) between impacts; the quadratic-drag Euler
recursion is a scalar loop. Each grid point holds at most one impact, so the work is bounded by
the number of grid points.

With the modal structure (structure.model = 3), each mode's closed form replaces the structure's
(:mod:`~iceimpact.solvers.fixed_step_modal`, through :meth:`FixedStepSolver._structure_at`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from ..errors import SolverError, StateError
from ..limits import EULER_STABILITY_LIMIT
from ..physics.contact import Impact, impact, impact_impulse
from ..physics.ice import make_drag
from ..physics.structure import Oscillator, morison_oscillator
from ..record import Record
from ..scene import DETECTION_WINDOW, Scene
from .base import Solver, State

#: Tolerance window of eq. 26: Delta = WINDOW_FRACTION * min(|v dt|, |w dt|).
WINDOW_FRACTION = 0.1

#: Steady-state thresholds (i)-(iii) of Section 4.1, in m, m/s and m/s^2 ("chosen through trial
#: and error" by the article's authors).
STEADY_THRESHOLD = 1e-4

#: The first SCALAR_STEPS grid points after an event are evaluated one by one (the next event may
#: be close: in a chatter the bodies meet at every grid point); later ones in vectorised chunks of
#: CHUNK_MIN points, doubling up to CHUNK_MAX while no event occurs.
SCALAR_STEPS = 8
CHUNK_MIN = 16
CHUNK_MAX = 16384

#: A time within this fraction of dt of a grid point is that grid point (rounding of t / dt).
GRID_SLACK = 1e-9

Grid = tuple[float, float, float, float]  # (x, v, z, w) at a grid point


class GridChunk(NamedTuple):
    """Grid points n0 + 1 ... n0 + count evaluated ahead (:meth:`FixedStepSolver._fill`)."""

    ns: np.ndarray          # grid point numbers, from the anchor
    x: np.ndarray           # structure displacement, m
    v: np.ndarray           # structure velocity, m/s
    z: np.ndarray           # ice displacement, m
    w: np.ndarray           # ice velocity, m/s
    first_event: int | None  # index of the first impact or steady state, if any
    hit: np.ndarray         # impact detected (eq. 26 window or sign change), per point
    v_prev: np.ndarray      # velocities at the previous grid point (backward differences of
    w_prev: np.ndarray      # the steady-state test (iii))


class FixedStepSolver(Solver):
    """The article's fixed-step scheme (method 2)."""

    name = "fixed-step"

    @property
    def penetration_cause(self) -> str:
        return ("the fixed-step method tests impacts on its grid points only"
                + (" and its eq. 26 window (solver.detection = 1) misses impacts"
                   if self.window else ""))

    def __init__(self, scene: Scene, record_impacts: bool = True):
        super().__init__(scene, record_impacts)
        self.dt = scene.solver_dt
        self.window = scene.solver_detection == DETECTION_WINDOW
        self.drag = make_drag(scene)
        self.u = scene.flow_u
        self.osc = self._oscillator(self.u)
        self.pinned = False
        self.pin_x = 0.0
        self._chunk = CHUNK_MIN
        self.max_penetration = 0.0      # deepest z - x at a detected impact, m (diagnostic)
        self.step_end = math.inf        # the end of the step being marched (advance_to), s
        s = self.state
        self._anchor(0.0, s.x, s.v, s.z, s.w)

    def _oscillator(self, u: float) -> Oscillator:
        """The structure's closed form (eq. 9-10) in a flow of speed u: with the linearised
        Morison drag on it (docs/explanation/morison.md), a damping b_s and an offset b_s u / k;
        the scene
        refuses the quadratic one for this method (no closed form)."""
        if self.structure_drag is None:
            return Oscillator(self.m, self.c, self.k)
        return morison_oscillator(self.m, self.c, self.k, self.structure_drag.b, u)

    def _pin_force(self) -> float:
        """The constant contact force of the steady state (eq. 28), N: the ice's drag k x
        (without the drag on the structure, which acts on it directly)."""
        if self.structure_drag is None:
            return self.k * self.pin_x
        return self.drag.force(0.0, self.u)

    # grid bookkeeping ----------------------------------------------------------------------------
    def _anchor(self, t: float, x: float, v: float, z: float, w: float) -> None:
        """Restart the closed forms (and the Euler recursion) at time t: local time 0."""
        self.t_a = t
        self.anchor = (x, v, z, w)
        self.n = 0                      # last grid point processed, counted from the anchor
        self._buf: GridChunk | None = None  # grid points evaluated ahead of n (see _fill)
        # where the look-ahead chunk starts: grid point and its state (None: no chunk)
        self._buf_start: tuple[int, Grid] | None = None
        self.grid: Grid = (x, v, z, w)  # state at that grid point (post-impact)

    def _pin_position(self) -> float:
        """Where eq. 27-29 pin the bodies: k x = F_drag(0), m."""
        force = self.drag.force(0.0, self.u)
        if self.structure_drag is not None:  # the flow drags the structure as well
            force += self.structure_drag.force(0.0, self.u)
        return force / self.k

    def _pin(self, t: float) -> None:
        """Steady state of eq. 27-29: k x = F_drag(0)."""
        self.pinned = True
        self.pin_x = self._pin_position()
        self._set_sticking(True, t)

    def _release(self, t: float) -> None:
        self.pinned = False
        self._set_sticking(False, t)
        self._anchor(t, self.pin_x, 0.0, self.pin_x, 0.0)

    def _structure_at(self, tau: float) -> tuple[float, float]:
        """The structure's (x, v) at local time tau from the anchor: its closed form (eq. 9-10)."""
        x_a, v_a = self.anchor[0], self.anchor[1]
        return self.osc.response(x_a, v_a, tau)

    def _structure_array(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_structure_at` at an array of local times."""
        x_a, v_a = self.anchor[0], self.anchor[1]
        return self.osc.response_array(x_a, v_a, tau)

    # marching ------------------------------------------------------------------------------------
    def _euler(self, n0: int, grid: Grid, count: int) -> tuple[np.ndarray, np.ndarray]:
        """Ice at the ``count`` grid points after n0 (state ``grid``) by explicit Euler (eq. 34
        and 36)."""
        _, _, z, w = grid
        u, dt, q = self.u, self.dt, self.drag.beta * self.dt
        zs, ws = [], []
        for i in range(count):
            r = w - u
            if q * abs(r) > EULER_STABILITY_LIMIT:
                self._unstable(r, n0 + i)
            z = z + w * dt             # eq. 34
            w = w - q * abs(r) * r     # eq. 36
            zs.append(z)
            ws.append(w)
        return np.array(zs), np.array(ws)

    def _unstable(self, r: float, n: int, h: float | None = None) -> None:
        """Eq. 36 maps r = w - u to r (1 - q |r|), q = (B/M) dt: beyond q |r| = 2 the relative
        velocity grows at every step and overflows to NaN. Stop the run with a clear error.
        ``h``: the length of a partial step from grid point n to a communication point
        (:meth:`_state_at`), shorter than dt, whose q = (B/M) h is beyond the limit."""
        q = self.drag.beta * self.dt
        limit = EULER_STABILITY_LIMIT
        t = self.t_a + n * self.dt
        where = (f"at t = {t:.9g} s: (B/M) dt |w - u| = {q * abs(r):.3g} > {limit:g}"
                 if h is None else
                 f"from the grid point at t = {t:.9g} s to the communication point "
                 f"{h:.3g} s later: (B/M) h |w - u| = {self.drag.beta * h * abs(r):.3g} > "
                 f"{limit:g} (and (B/M) dt |w - u| = {q * abs(r):.3g} for the grid's next step)")
        raise SolverError(
            f"solver.dt = {self.dt!r} s is too large for the explicit Euler step of the quadratic "
            f"drag (eq. 36) {where}, so the ice velocity would diverge; use "
            f"solver.dt < {limit / (self.drag.beta * abs(r)):.3g} s, or solver.method = 1")

    def _pinnable(self) -> bool:
        """The steady state of eq. 27-29 presses the ice on the structure with k x = F_drag(0):
        it exists only while the drag pushes (u >= 0). A contact cannot pull, so with a reversed
        flow the bodies are never pinned (the ice drifts away instead). And only where that
        position is within threshold (i) itself: the thresholds hold near x = 0, and a pin at a
        far equilibrium (b u / k = 8e170 m on k = 8e-182 N/m) moved the bodies there in one
        grid step, creating its energy k x^2 / 2."""
        return (self.drag.force(0.0, self.u) >= 0.0
                and abs(self._pin_position()) < STEADY_THRESHOLD)

    def _steady(self, x, v, z, w, v_prev, w_prev) -> np.ndarray:
        """Conditions (i)-(iii) of Section 4.1 at each grid point of a chunk."""
        lim = STEADY_THRESHOLD
        return (self._pinnable()
                & (np.maximum(np.abs(x), np.abs(z)) < lim)
                & (np.maximum(np.abs(v), np.abs(w)) < lim)
                & (np.maximum(np.abs(v - v_prev), np.abs(w - w_prev)) < lim * self.dt))

    def _steady_at(self, x: float, v: float, z: float, w: float, v_prev: float,
                   w_prev: float) -> bool:
        """Conditions (i)-(iii) of Section 4.1 at one grid point."""
        lim = STEADY_THRESHOLD
        return (self._pinnable() and abs(x) < lim and abs(z) < lim and abs(v) < lim and abs(w) < lim
                and abs(v - v_prev) < lim * self.dt and abs(w - w_prev) < lim * self.dt)

    def _fill(self, n0: int, grid: Grid) -> None:
        """Evaluate the chunk of grid points after n0 (state ``grid``) and find its first event.

        The grid does not depend on the communication step, so the chunk is computed ahead and
        consumed by as many ``advance_to`` calls as it spans. A snapshot keeps where the chunk
        starts, so a restored solver computes the same chunk with the same arithmetic.
        """
        dt = self.dt
        _, _, z_a, w_a = self.anchor
        ns = np.arange(n0 + 1, n0 + self._chunk + 1)
        tau = ns * dt
        x, v = self._structure_array(tau)
        if self.drag.quadratic:
            z, w = self._euler(n0, grid, ns.size)
        else:
            z, w = self.drag.motion_array(z_a, w_a, self.u, tau)
        gap = x - z
        if self.window:  # eq. 26
            delta = WINDOW_FRACTION * dt * np.minimum(np.abs(v), np.abs(w))
            hit = (np.abs(gap) <= delta) & (w > v)
        else:
            hit = (gap <= 0.0) & (w > v)
        _, v_last, _, w_last = grid
        v_prev = np.concatenate(([v_last], v[:-1]))
        w_prev = np.concatenate(([w_last], w[:-1]))
        flags = hit | self._steady(x, v, z, w, v_prev, w_prev)
        j = int(np.argmax(flags)) if flags.any() else None
        self._buf = GridChunk(ns, x, v, z, w, j, hit, v_prev, w_prev)
        self._buf_start = (n0, grid)

    def _march_scalar(self) -> float:
        """Process grid point n + 1 alone (right after an event, where the next one may follow)."""
        n = self.n + 1
        _, _, z_a, w_a = self.anchor
        tau = n * self.dt
        x, v = self._structure_at(tau)
        _, v_prev, z, w_prev = self.grid
        if self.drag.quadratic:  # eq. 34 and 36
            r = w_prev - self.u
            if self.drag.beta * self.dt * abs(r) > EULER_STABILITY_LIMIT:
                self._unstable(r, self.n)
            z, w = z + w_prev * self.dt, w_prev - self.drag.beta * self.dt * abs(r) * r
        else:
            z, w = self.drag.motion(z_a, w_a, self.u, tau)
        gap = x - z
        if self.window:  # eq. 26
            hit = abs(gap) <= WINDOW_FRACTION * self.dt * min(abs(v), abs(w)) and w > v
        else:
            hit = gap <= 0.0 and w > v
        if hit or self._steady_at(x, v, z, w, v_prev, w_prev):
            return self._event(n, x, v, z, w, hit, v_prev, w_prev)
        self.n, self.grid = n, (x, v, z, w)
        return 0.0

    def _march(self, n_end: int) -> float:
        """Process grid points up to ``n_end``; stop after the first impact or steady state.

        Returns the impulse of that impact on the structure (0 if none).
        """
        if self._buf_start is None and self.n < SCALAR_STEPS:
            return self._march_scalar()
        if self._buf is None:  # a new chunk from n, or the one a snapshot started
            self._fill(*(self._buf_start or (self.n, self.grid)))
        ns, x, v, z, w, j, hit, v_prev, w_prev = self._buf
        if j is None or ns[j] > n_end:  # no event up to n_end: consume grid points
            i = min(n_end, int(ns[-1])) - int(ns[0])
            self.n = int(ns[i])
            self.grid = (float(x[i]), float(v[i]), float(z[i]), float(w[i]))
            if i == ns.size - 1:
                self._buf = self._buf_start = None
                self._chunk = min(2 * self._chunk, CHUNK_MAX)
            return 0.0
        return self._event(int(ns[j]), float(x[j]), float(v[j]), float(z[j]), float(w[j]),
                           bool(hit[j]), float(v_prev[j]), float(w_prev[j]))

    def _event(self, n: int, x: float, v: float, z: float, w: float, hit: bool,
               v_prev: float, w_prev: float) -> float:
        """Impact (eq. 16-17) and/or steady state (eq. 27-29) at grid point n; the impulse."""
        self._chunk = CHUNK_MIN
        # a grid point within GRID_SLACK of the step's end is the step's end (advance_to's n_end):
        # its time is t_end, not t_a + n dt rounded past it, which put the impact, the new grid's
        # anchor and the pin after the state's own time (a saved state its restore refused)
        t = min(self.t_a + n * self.dt, self.step_end)
        impulse = 0.0
        if hit:  # both bodies restart from the structure's position x_k (eq. 24)
            self.max_penetration = max(self.max_penetration, z - x)
            v_plus, w_plus = impact(v, w, self.m, self.M, self.e)
            impulse = impact_impulse(v, v_plus, self.m)
            self._record(Impact(t, x, v, w, v_plus, w_plus, impulse, self.e))
            v, z, w = v_plus, x, w_plus
        self._anchor(t, x, v, z, w)
        if self._steady_at(x, v, z, w, v_prev, w_prev):
            self._pin(t)
        return impulse

    def _state_at(self, t: float) -> State:
        """State at time t >= the last grid point, without touching the grid."""
        if self.pinned:
            return State(t, self.pin_x, 0.0, self.pin_x, 0.0)
        h = t - (self.t_a + self.n * self.dt)
        if h <= GRID_SLACK * self.dt:
            return State(t, *self.grid)
        _, _, z_a, w_a = self.anchor
        tau = t - self.t_a
        x, v = self._structure_at(tau)
        if self.drag.quadratic:  # a partial Euler step from the last grid point
            _, _, z, w = self.grid
            # held to eq. 36's stability limit as the grid's steps are: an impact at the grid
            # point may have given the ice a speed whose full step the march would refuse, and
            # beyond the limit the partial step multiplies |w - u| by (B/M) h |w - u| - 1 (a
            # 1 g floe struck by a 1e9 kg structure at 5e20 m/s: 1.35e22, and the bodies'
            # energy 1e19 times the scene's at u = 0)
            r = w - self.u
            if self.drag.beta * h * abs(r) > EULER_STABILITY_LIMIT:
                self._unstable(r, self.n, h)
            z, w = z + w * h, w + self.drag.force(w, self.u) / self.M * h
        else:
            z, w = self.drag.motion(z_a, w_a, self.u, tau)
        return State(t, x, v, z, w)

    def advance_to(self, t_end: float, u: float, stop_at_event: bool = False) -> float:
        # (stop_at_event is not taken: the scheme finds impacts at its grid points only, and a
        # step that ended at one would move the grid of the steps after it)
        t_now = self.state.t
        if u != self.u:  # zero-order hold: a new grid starts at the change
            s = self.state
            self.u = u
            if self.structure_drag is not None:
                self.osc = self._oscillator(u)
            if self.pinned:
                self._release(t_now)
            else:
                self._anchor(t_now, s.x, s.v, s.z, s.w)
        impulse = 0.0
        self.step_end = t_end
        n_end = math.floor((t_end - self.t_a) / self.dt + GRID_SLACK)
        while not self.pinned and self.n < n_end:
            impulse += self._march(n_end)
            n_end = math.floor((t_end - self.t_a) / self.dt + GRID_SLACK)
        if self.pinned:  # constant contact force k x = F since the pin (eq. 28)
            impulse += self._pin_force() * (t_end - max(t_now, self.sticking_since))
        self.state = self._state_at(t_end)
        return impulse

    # snapshots ----------------------------------------------------------------------------------
    _KEYS = ("u", "pinned", "pin_x", "chunk", "max_penetration", "t_a", "anchor", "n", "grid",
             "buffer")

    def _snapshot(self) -> dict[str, Any]:
        buffer = None
        if self._buf_start is not None:
            n0, grid = self._buf_start
            buffer = {"n": n0, "grid": list(grid)}
        return {"u": self.u, "pinned": self.pinned, "pin_x": self.pin_x, "chunk": self._chunk,
                "max_penetration": self.max_penetration, "t_a": self.t_a,
                "anchor": list(self.anchor), "n": self.n, "grid": list(self.grid),
                "buffer": buffer}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        u = rec.real("u")
        pinned = rec.flag("pinned")
        if pinned != rec.data["sticking"]:
            raise StateError(rec.field("pinned"), pinned, "equal to sticking (method 2 sticks "
                             "only when pinned at its steady state)")
        pin_x = rec.real("pin_x")
        chunk = rec.integer("chunk", low=CHUNK_MIN, high=CHUNK_MAX)
        max_penetration = rec.real("max_penetration", low=0.0)
        t_a = rec.real("t_a", low=0.0, high=t)
        anchor = tuple(rec.reals("anchor", 4))
        n = rec.integer("n", low=0)
        grid = tuple(rec.reals("grid", 4))
        buffer = rec.record("buffer", allow_none=True)
        start = None
        if buffer is not None:
            buffer.expect_keys(("n", "grid"))
            n0 = buffer.integer("n", low=0, high=n)
            if n > n0 + chunk:
                raise StateError(buffer.field("n"), n0, f">= n - chunk = {n - chunk} (the "
                                 "look-ahead chunk holds the current grid point)")
            start = (n0, tuple(buffer.reals("grid", 4)))

        def apply() -> None:
            self.u, self.pinned, self.pin_x = u, pinned, pin_x
            self.osc = self._oscillator(u)
            self._chunk, self.max_penetration = chunk, max_penetration
            self.t_a, self.anchor, self.n, self.grid = t_a, anchor, n, grid
            self._buf, self._buf_start = None, start
        return apply
