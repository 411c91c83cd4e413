"""Stepping API and direct runs: what the FMU, the CLI and scripts call.

Two levels, like FMPy's ``simulate_fmu`` over ``FMU2Slave``:

- :class:`Simulator`: ``advance(h, u)`` over one communication step with the flow speed held
  constant (zero-order hold), returning a :class:`StepReport`; ``save``/``restore`` for roll-back.
- :func:`run`: a whole simulation at constant flow, returning a :class:`Result` with the impact
  list and the states sampled at requested times, as numpy arrays.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from .scene import METHOD_EXACT, METHOD_FIXED_STEP, METHOD_ODE, ParameterError, Scene, validate_flow
from .solvers.base import Impact, Solver, SolverError
from .solvers.event import EventSolver
from .solvers.fixed_step import FixedStepSolver
from .solvers.ode import OdeSolver

_SOLVERS: dict[int, type[Solver]] = {METHOD_EXACT: EventSolver, METHOD_FIXED_STEP: FixedStepSolver,
                                     METHOD_ODE: OdeSolver}

#: Gaps between -GAP_ROUNDING and 0 are rounding of x - z at contact and reported as 0.
GAP_ROUNDING = 1e-12


def make_solver(scene: Scene) -> Solver:
    """The solver object for ``scene.solver_method``."""
    try:
        cls = _SOLVERS[scene.solver_method]
    except KeyError:
        raise ParameterError("solver.method", scene.solver_method,
                             "1 (exact), 2 (fixed-step) or 3 (ODE)") from None
    return cls(scene)


@dataclass(frozen=True)
class StepReport:
    """Outputs at the end of one communication step (the FMU's outputs, SI units)."""

    t: float             # s
    x: float             # structure displacement, m
    v: float             # structure velocity, m/s
    z: float             # ice displacement, m
    w: float             # ice velocity, m/s
    gap: float           # x - z, m, >= 0 (0 while the ice is past the structure)
    penetration: float   # z - x when the ice is past the structure, else 0, m (methods 2, 3)
    impulse: float       # impulse on the structure during the step (impacts + sticking), N.s
    force: float         # impulse / h, mean contact force over the step, N
    impacts: int         # impacts during the step
    impact_count: int    # impacts since the start
    t_last: float        # time of the latest impact, s (-1 before the first)
    sticking: bool       # bodies stick together at the end of the step


class Simulator:
    """Marches one scene step by step: ``advance(h, u)`` is one communication step."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self.solver = make_solver(scene)
        self._n_reported = 0  # impacts already reported (an impact at t = 0 goes to step 1)
        self.failed: str | None = None  # why the run stopped (a SolverError), if it did
        self.report = self._report(0.0, 0.0)

    @property
    def t(self) -> float:
        return self.solver.t

    @property
    def impacts(self) -> list[Impact]:
        return self.solver.impacts

    def advance(self, h: float, u: float | None = None) -> StepReport:
        """Advance by the communication step ``h`` (s) with flow speed ``u`` (m/s) held constant.

        ``u`` defaults to the scene's ``flow.u``. Raises :class:`ParameterError` for a step that
        is not a positive finite number or a flow speed that is not finite (nothing changes), and
        :class:`SolverError` when the method cannot continue; the run then stays stopped, and
        every later call raises the same error.
        """
        if isinstance(h, bool) or not isinstance(h, int | float) or not (math.isfinite(h)
                                                                          and h > 0.0):
            raise ParameterError("communication step", h, "a finite number > 0 (s)")
        u = self.scene.flow_u if u is None else validate_flow(u, self.scene)
        if self.failed is not None:
            raise SolverError(self.failed)
        t_end = self.solver.t + h
        try:
            impulse = self.solver.advance_to(t_end, u)
        except SolverError as exc:  # the state is not trustworthy any more: stop the run
            self.failed = f"the run stopped: {exc}"
            raise SolverError(self.failed) from exc
        self.report = self._report(impulse, h)
        self._n_reported = len(self.solver.impacts)
        return self.report

    def _report(self, impulse: float, h: float) -> StepReport:
        s = self.solver.state
        # Method 1 keeps x - z >= 0 up to rounding; method 3 up to its integration error (atol
        # = 1e-3 rtol m). The fixed-step scheme (method 2) tests impacts on grid points only,
        # so the ice can be up to one step's closing distance past the structure, or pass
        # through it when its eq. 26 window misses an impact. A negative x - z is reported as a
        # penetration, not as a negative gap.
        gap = s.x - s.z
        penetration = 0.0
        if gap < 0.0:
            penetration = -gap if gap <= -GAP_ROUNDING else 0.0
            gap = 0.0
        impacts = self.solver.impacts
        return StepReport(
            t=s.t, x=s.x, v=s.v, z=s.z, w=s.w, gap=gap, penetration=penetration, impulse=impulse,
            force=impulse / h if h > 0.0 else 0.0, impacts=len(impacts) - self._n_reported,
            impact_count=len(impacts),
            t_last=impacts[-1].t if impacts else -1.0, sticking=self.solver.sticking)

    def set_restitution(self, e: float) -> None:
        """Change ``impact.e`` (tunable) for impacts from now on; 0 <= e <= 1."""
        if (isinstance(e, bool) or not isinstance(e, int | float) or not math.isfinite(e)
                or not 0.0 <= e <= 1.0):
            raise ParameterError("impact.e", e, "0 <= e <= 1")
        self.scene = self.scene.replace(impact_e=float(e))
        self.solver.set_restitution(float(e))

    def save(self) -> object:
        """A deep copy of the whole internal state (for FMI get/set FMU state)."""
        return copy.deepcopy((self.scene, self.solver, self.report, self._n_reported))

    def restore(self, snapshot: object) -> None:
        """Return to a state from :meth:`save` (the snapshot stays reusable)."""
        self.scene, self.solver, self.report, self._n_reported = copy.deepcopy(snapshot)


@dataclass
class Result:
    """A whole run: samples (arrays over ``t``) and the impact list (arrays over impacts)."""

    scene: Scene
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    z: np.ndarray
    w: np.ndarray
    impulse: np.ndarray        # impulse on the structure in each sample interval, N.s
    sticking: np.ndarray       # bool per sample
    impacts: np.ndarray        # structured array, fields of :class:`Impact`
    sticking_since: float | None

    @property
    def gap(self) -> np.ndarray:
        return self.x - self.z

    @property
    def impact_times(self) -> np.ndarray:
        return self.impacts["t"]


IMPACT_DTYPE = np.dtype([(name, float) for name in Impact._fields])


def impacts_array(impacts: list[Impact]) -> np.ndarray:
    """The impact list as a structured numpy array (fields t, x, v_minus, ..., restitution)."""
    return np.array([tuple(i) for i in impacts], dtype=IMPACT_DTYPE)


def run(scene: Scene, t_end: float, dt: float = 1e-2,
        sample_times: np.ndarray | None = None) -> Result:
    """Simulate ``scene`` at its constant flow speed from 0 to ``t_end`` (s).

    States are sampled every ``dt`` (s), or at ``sample_times`` (increasing, in (0, t_end]).
    Sampling does not change the trajectory: flights stay anchored at their events.
    """
    if not (math.isfinite(t_end) and t_end > 0.0):
        raise ParameterError("t_end", t_end, "a finite number > 0 (s)")
    if sample_times is None:
        if not (math.isfinite(dt) and dt > 0.0):
            raise ParameterError("dt", dt, "a finite number > 0 (s)")
        n = int(math.floor(t_end / dt + 1e-9))
        sample_times = dt * np.arange(1, n + 1)
        if n == 0 or sample_times[-1] < t_end * (1 - 1e-12):
            sample_times = np.append(sample_times, t_end)
    sample_times = np.asarray(sample_times, dtype=float)
    if sample_times.size and (np.any(np.diff(sample_times) <= 0) or sample_times[0] <= 0.0):
        raise ParameterError("sample_times", "...", "strictly increasing and > 0")
    sim = Simulator(scene)
    solver = sim.solver
    u = scene.flow_u
    s0 = solver.state
    rows = [(0.0, s0.x, s0.v, s0.z, s0.w, 0.0, solver.sticking)]
    for t in sample_times:
        impulse = solver.advance_to(float(t), u)
        s = solver.state
        rows.append((s.t, s.x, s.v, s.z, s.w, impulse, solver.sticking))
    cols = list(zip(*rows, strict=True))
    return Result(scene=scene, t=np.array(cols[0]), x=np.array(cols[1]), v=np.array(cols[2]),
                  z=np.array(cols[3]), w=np.array(cols[4]), impulse=np.array(cols[5]),
                  sticking=np.array(cols[6], dtype=bool), impacts=impacts_array(solver.impacts),
                  sticking_since=solver.sticking_since)
