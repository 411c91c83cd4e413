"""The extremes matrix: corner scenes x both drag laws x the three solver methods.

Each cell is a variation of the article's Figure 2 scene (m = M = 1600 kg, k = 1 MN/m, u = 0.1
m/s, omega_n = 25 rad/s) pushed to one extreme. :func:`run_cell` steps the core
:class:`iceimpact.Simulator` through it and measures; :func:`failures` says which requirement a
measurement breaks:

- every output finite;
- the gap x - z >= -1e-12 m at every communication point (method 1), >= -10 atol = -1e-10 m
  (method 3, whose positions carry its integration error); method 2 (the article's fixed-step
  scheme, with the sign test): the ice at most one grid step's closing distance past the
  structure, since that scheme tests impacts on grid points only;
- momentum conserved at every impact (relative 1e-12);
- with u = 0, the energy never grows (drag, damping and impacts only take energy away), and where
  nothing dissipates (c = 0, Cd = 0, e = 1) it stays constant;
- bounded work: the run finishes within :data:`TIME_LIMIT` and :data:`MAX_IMPACTS`;
- method 1 agrees with an independent scipy integration (``ode_reference``, DOP853 at rtol 1e-12)
  on the impact times of the first :data:`REFERENCE_HORIZON` seconds;
- a combination a method does not support (the quadratic Morison drag on the structure with the
  fixed-step method, which has no closed form for it) is refused with a ParameterError, and only
  where the cell says so (``refused``).

Run as a script to print the matrix as the Markdown table the robustness explanation includes
(docs/explanation/robustness/index.md)::

    python tests/extremes.py > benchmarks/results/extremes_matrix.md
"""

from __future__ import annotations

import dataclasses
import math
import signal
import sys
import time
from dataclasses import dataclass, field

import numpy as np

import ode_reference
from iceimpact import ParameterError, Scene, Simulator

#: A cell that runs longer than this (s of wall time) has stalled.
TIME_LIMIT = 60.0
#: More impacts than this in a cell is an unbounded (Zeno) sequence.
MAX_IMPACTS = 100_000
#: Horizon (s) of the comparison with the scipy reference, and the impacts compared.
REFERENCE_HORIZON = 2.0
REFERENCE_IMPACTS = 10
#: Largest impact-time difference (s) from the scipy reference.
REFERENCE_TOLERANCE = 1e-8
#: Energy growth tolerated at u = 0, relative to the initial energy: rounding for methods 1 and 2
#: (closed forms), the integration tolerance for method 3 (rtol 1e-8).
ENERGY_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}

#: Method 3 locates impacts on positions that carry its integration error, controlled per step by
#: atol = 1e-3 rtol (m), 1e-11 m at the default rtol 1e-8; globally up to a few times that.
ODE_GAP_TOLERANCE = 10 * 1e-3 * Scene().solver_rtol

K, M_STRUCT = 1.0e6, 1600.0
#: A 1 m diameter leg with 1 m of draft: added mass rho pi/4 m^3 = 785 kg, drag area 1 m^2.
PILE = {"structure_Ca": 1.0, "structure_V": math.pi / 4, "structure_Cd": 1.0,
        "structure_A": 1.0}
C_CRITICAL = 2.0 * math.sqrt(K * M_STRUCT)  # 80,000 N.s/m exactly (sqrt(1.6e9) = 40,000)


@dataclass(frozen=True)
class Cell:
    """One corner: changes to the Figure 2 scene, horizon and communication step (s)."""

    name: str
    changes: dict
    t_end: float = 5.0
    h: float = 1e-3
    t_end_ode: float | None = None  # a shorter horizon for method 3 where it is costly
    flow: tuple[tuple[float, float], ...] = ()  # (from time, u) changes of the flow input
    conservative: bool = False  # nothing dissipates: energy constant
    reference: bool = True  # compare method 1 with scipy (off where another cell already does)
    refused: tuple[tuple[int, int], ...] = ()  # (drag, method) the scene refuses, by design
    # (drag, method) -> the one failure a method is known to show here, and why (docs)
    known: dict = field(default_factory=dict)


CELLS: tuple[Cell, ...] = (
    Cell("e = 0 (plastic)", {"impact_e": 0.0}),
    Cell("e = 1 (elastic)", {"impact_e": 1.0}),
    Cell("M/m = 1e-3", {"ice_M": 1.6}),
    Cell("M/m = 1e3", {"ice_M": 1.6e6}),
    Cell("u = 0", {"flow_u": 0.0}),
    Cell("u = 0, e = 0", {"flow_u": 0.0, "impact_e": 0.0}),
    Cell("u = 0, M/m = 1e3", {"flow_u": 0.0, "ice_M": 1.6e6}),
    Cell("u = 0, zeta = 5", {"flow_u": 0.0, "structure_c": 5 * C_CRITICAL}),
    Cell("u = 0, c = 0, Cd = 0, e = 1", {"flow_u": 0.0, "structure_c": 0.0, "ice_Cd": 0.0},
         conservative=True),
    Cell("u = 1e-6 m/s", {"flow_u": 1e-6}),
    Cell("u = 10 m/s", {"flow_u": 10.0}),
    Cell("c = 0", {"structure_c": 0.0}),
    Cell("zeta = 1 - 1e-8", {"structure_c": (1 - 1e-8) * C_CRITICAL}),
    Cell("zeta = 1", {"structure_c": C_CRITICAL}),
    Cell("zeta = 5", {"structure_c": 5 * C_CRITICAL}),
    Cell("omega_n = 0.1 rad/s", {"structure_k": M_STRUCT * 0.1 ** 2}, t_end=60.0, h=0.01),
    Cell("omega_n = 1e4 rad/s", {"structure_k": M_STRUCT * 1e4 ** 2}, t_end=2.0,
         t_end_ode=0.5),
    Cell("contact, ice moving towards", {"ice_z0": 0.0, "ice_v0": 0.01}),
    Cell("contact, ice moving away", {"ice_z0": 0.0, "ice_v0": -0.01}),
    Cell("contact, at rest", {"ice_z0": 0.0, "ice_v0": 0.0}),
    Cell("contact, same speed", {"ice_z0": 0.0, "ice_v0": 0.01, "structure_v0": 0.01}),
    # nothing moves and no force acts: the contact force is exactly zero throughout (method 3
    # once re-formed the contact every microsecond here; found by random search)
    Cell("contact, at rest, no force at all", {"ice_z0": 0.0, "ice_v0": 0.0, "flow_u": 0.0,
                                               "ice_Cd": 0.0, "structure_c": 0.0,
                                               "impact_e": 0.0}),
    Cell("step 1e-6 s", {"ice_z0": -1e-4}, t_end=0.02, h=1e-6),
    Cell("step 10 s (40 periods)", {}, t_end=100.0, h=10.0, t_end_ode=20.0),
    Cell("step 10 s, omega_n = 1e4", {"structure_k": M_STRUCT * 1e4 ** 2}, t_end=20.0, h=10.0,
         t_end_ode=0.0, reference=False),  # the omega_n = 1e4 cell compares with scipy
    Cell("flow reversing, e = 1", {}, t_end=30.0, h=1e-2, t_end_ode=15.0,
         flow=((10.0, -0.1), (20.0, 0.1))),
    Cell("flow reversing while sticking", {"impact_e": 0.5}, t_end=30.0, h=1e-2,
         t_end_ode=30.0, flow=((15.0, -0.1), (22.0, 0.3))),
    # Morison loads on the structure (docs/explanation/morison.md); method 2 has no closed form
    # for the quadratic drag on the structure and refuses it
    Cell("Morison: 1 m leg (Ca, V, Cd, A)", PILE, refused=((2, 2),)),
    Cell("Morison: m_a = 10 m, e = 0.5",
         {**PILE, "structure_V": 16000.0 / 999.0, "impact_e": 0.5}, refused=((2, 2),)),
    Cell("Morison: u = 0, structure drag over-damps", {"flow_u": 0.0, "structure_Cd": 1.0,
                                                       "structure_A": 1.0e4},
         refused=((2, 2),)),
    Cell("Morison: flow reversing, e = 0.5", {**PILE, "impact_e": 0.5}, t_end=30.0, h=1e-2,
         t_end_ode=15.0, flow=((10.0, -0.1), (20.0, 0.3)), refused=((2, 2),)),
    # (method 3 steps over a shallow touch at 4.587 s here, -3.28e-6 m, unless it looks for
    # meetings inside its steps: docs/explanation/robustness/ode.md#hidden-meeting)
)


@dataclass
class CellResult:
    cell: Cell
    drag: int
    method: int
    finished: bool = True
    t_reached: float = 0.0
    finite: bool = True
    min_gap: float = math.inf          # m, min of x - z at communication points
    penetration_bound: float = 0.0     # m, one grid step's closing distance (method 2)
    momentum_error: float = 0.0        # relative
    energy_growth: float | None = None  # relative to the initial energy, u = 0 only
    energy_drift: float | None = None   # relative, conservative cells only
    impacts: int = 0
    sticking: bool = False
    wall: float = 0.0
    reference_error: float | None = None  # s
    reference_count: int = 0
    impact_times: np.ndarray = field(default_factory=lambda: np.empty(0))  # s
    notes: list[str] = field(default_factory=list)


class _Stalled(Exception):
    pass


def _alarm(signum, frame):
    raise _Stalled


def scene_of(cell: Cell, drag: int, method: int) -> Scene:
    # method 2 with the sign test: the eq. 26 window misses impacts by design
    # (docs/explanation/accuracy.md)
    return Scene(**{**cell.changes, "drag_model": drag, "solver_method": method,
                    "solver_detection": 2})


def fmi_values(cell: Cell, drag: int, method: int) -> dict:
    """The cell's scene as FMI-named start values, unvalidated (for the refused cells)."""
    from iceimpact.contract import SCENE_VARIABLES

    by_field = {v.field: name for name, v in SCENE_VARIABLES.items()}
    values = {**Scene().to_fmi(), "drag.model": drag, "solver.method": method,
              "solver.detection": 2}
    values.update({by_field[f]: value for f, value in cell.changes.items()})
    return values


def _structure_mass(scene: Scene) -> float:
    """m + rho Ca V: the added mass moves with the structure (written out, not the scene's)."""
    return scene.structure_m + scene.fluid_rho * scene.structure_Ca * scene.structure_V


def _energy(scene: Scene, x, v, w) -> np.ndarray:
    return (0.5 * _structure_mass(scene) * np.square(v) + 0.5 * scene.structure_k * np.square(x)
            + 0.5 * scene.ice_M * np.square(w))


def run_cell(cell: Cell, drag: int, method: int, h: float | None = None,
             reference: bool = True) -> CellResult:
    """Step the cell through the core and measure it (see the module docstring); ``h`` (s)
    replaces the cell's communication step; ``reference=False`` skips the scipy comparison."""
    if h is not None:
        cell = dataclasses.replace(cell, h=h)
    res = CellResult(cell, drag, method)
    try:
        scene = scene_of(cell, drag, method)
    except ParameterError as exc:
        if (drag, method) not in cell.refused:
            raise
        res.finished = False
        res.notes.append(f"refused: {exc}")
        return res
    t_end = cell.t_end if method != 3 or cell.t_end_ode is None else cell.t_end_ode
    if t_end <= 0.0:
        res.notes.append("not run (method 3 integrates every oscillation: too costly)")
        res.finished = False
        return res
    sim = Simulator(scene)
    flow = [(0.0, scene.flow_u), *cell.flow]
    rows = [(sim.t, *_state(sim))]
    n_steps = round(t_end / cell.h)
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT)
    start = time.perf_counter()
    try:
        for k in range(n_steps):
            t = k * cell.h
            u = [u for since, u in flow if since <= t + 1e-12][-1]
            r = sim.advance((k + 1) * cell.h - t, u)
            rows.append((r.t, *_state(sim)))
            res.finite &= all(math.isfinite(getattr(r, f)) for f in (
                "x", "v", "z", "w", "gap", "penetration", "impulse", "force", "t_last"))
            if len(sim.impacts) > MAX_IMPACTS:
                res.finished = False
                res.notes.append(f"over {MAX_IMPACTS} impacts")
                break
    except _Stalled:
        res.finished = False
        res.notes.append(f"stalled: over {TIME_LIMIT} s of wall time at t = {sim.t:.6g} s")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)
    res.wall = time.perf_counter() - start
    res.t_reached = sim.t
    res.impacts = len(sim.impacts)
    res.impact_times = np.array([i.t for i in sim.impacts])
    res.sticking = sim.solver.sticking
    t, x, v, z, w = np.array(rows).T
    res.min_gap = float(np.min(x - z))
    if method == 2:
        res.penetration_bound = float(np.max(np.abs(w - v))) * scene.solver_dt
    m, M = _structure_mass(scene), scene.ice_M
    for i in sim.impacts:
        scale = m * abs(i.v_minus) + M * abs(i.w_minus)
        err = abs(m * i.v_plus + M * i.w_plus - m * i.v_minus - M * i.w_minus)
        res.momentum_error = max(res.momentum_error, err / scale if scale else err)
    if all(u == 0.0 for _, u in flow):
        energy = _energy(scene, x, v, w)
        e0 = energy[0]
        growth = float(np.max(np.diff(energy), initial=0.0))
        # relative to the initial energy; absolute (J) when the bodies start at rest
        res.energy_growth = growth / e0 if e0 > 0.0 else growth
        if cell.conservative:
            res.energy_drift = float(np.max(np.abs(energy - e0)) / e0)
    if method == 1 and res.finished and reference and cell.reference:
        _compare_with_reference(res, scene, sim)
    return res


def _state(sim: Simulator) -> tuple[float, float, float, float]:
    s = sim.solver.state
    return s.x, s.v, s.z, s.w


def _compare_with_reference(res: CellResult, scene: Scene, sim: Simulator) -> None:
    """Impact times of the first REFERENCE_HORIZON s against DOP853 at rtol 1e-12 (constant flow
    over that horizon in every cell)."""
    horizon = min(REFERENCE_HORIZON, res.t_reached)
    # absolute tolerances scaled to the scene's displacements (omega_n up to 1e4 rad/s: um)
    scale = max(abs(scene.ice_z0), abs(scene.ice_v0) / scene.omega_n, 1e-6)
    ref = ode_reference.simulate(scene, horizon, max_impacts=REFERENCE_IMPACTS,
                                 atol=1e-13 * scale)
    ours = np.array([i.t for i in sim.impacts if i.t <= horizon][:REFERENCE_IMPACTS])
    n = min(len(ours), len(ref["t"]))
    res.reference_count = n
    res.reference_error = float(np.max(np.abs(ours[:n] - ref["t"][:n]), initial=0.0))
    if len(ours) != len(ref["t"]) and min(len(ours), len(ref["t"])) < REFERENCE_IMPACTS:
        # the reference stops at a Zeno sequence (closing speed < 1e-9 m/s), which the exact
        # solver closes by its chatter rule or continues as sticking contact
        res.notes.append(f"reference stops after {len(ref['t'])} impacts, exact solver has "
                         f"{len(ours)} in {horizon:g} s")


def failures(res: CellResult) -> list[str]:
    """The requirements this cell breaks (empty: it passes)."""
    out = []
    if not res.finished and not res.notes[0].startswith(("not run", "refused")):
        out.append("; ".join(res.notes))
    if res.notes and res.notes[0].startswith("refused") and (
            (res.drag, res.method) not in res.cell.refused):
        out.append("; ".join(res.notes))
    if not res.finite:
        out.append("non-finite output")
    if res.method == 2:
        if -res.min_gap > res.penetration_bound + 1e-12:
            out.append(f"ice {-res.min_gap:.3g} m past the structure, more than one grid step's "
                       f"closing distance {res.penetration_bound:.3g} m")
    elif res.min_gap < -(1e-12 if res.method == 1 else ODE_GAP_TOLERANCE):
        out.append(f"negative gap {res.min_gap:.3g} m")
    if res.momentum_error > 1e-12:
        out.append(f"momentum error {res.momentum_error:.3g}")
    if res.energy_growth is not None and res.energy_growth > ENERGY_TOLERANCE[res.method]:
        out.append(f"energy grows by {res.energy_growth:.3g} at u = 0")
    if res.energy_drift is not None and res.energy_drift > ENERGY_TOLERANCE[res.method]:
        out.append(f"energy not conserved: drift {res.energy_drift:.3g}")
    if res.reference_error is not None and res.reference_error > REFERENCE_TOLERANCE:
        out.append(f"impact times differ from scipy by {res.reference_error:.3g} s")
    return out


def markdown_table(results: list[CellResult]) -> str:
    """The matrix as Markdown: one row per cell and drag law, one column per method."""
    lines = ["| cell | drag | method 1 (exact) | method 2 (fixed-step) | method 3 (ODE) |",
             "|---|---|---|---|---|"]
    by_key = {(r.cell.name, r.drag, r.method): r for r in results}
    for cell in CELLS:
        for drag in (1, 2):
            cols = []
            for method in (1, 2, 3):
                r = by_key.get((cell.name, drag, method))
                cols.append(_summary(r) if r is not None else "")
            lines.append(f"| {cell.name} | {'linear' if drag == 1 else 'quadratic'} | "
                         + " | ".join(cols) + " |")
    return "\n".join(lines)


def _summary(r: CellResult) -> str:
    if not r.finished and r.notes and r.notes[0].startswith("not run"):
        return "not run"
    if not r.finished and r.notes and r.notes[0].startswith("refused"):
        return "refused (ParameterError, no closed form)"
    bad = failures(r)
    known = r.cell.known.get((r.drag, r.method))
    verdict = ("ok" if not bad else f"known limitation: {known}" if bad == [known]
               else "**FAIL: " + "; ".join(bad) + "**")
    parts = [verdict,
             f"{r.impacts} imp." + (", sticks" if r.sticking else "")]
    if r.method == 2 and r.min_gap < 0:
        parts.append(f"pen. {-r.min_gap:.1e} m")
    if r.energy_drift is not None:
        parts.append(f"dE {r.energy_drift:.0e}")
    if r.reference_error is not None and r.reference_count:
        parts.append(f"vs scipy {r.reference_error:.0e} s ({r.reference_count})")
    parts.append(f"{r.wall:.2f} s")
    return ", ".join(parts)


if __name__ == "__main__":
    results = []
    for cell in CELLS:
        for drag in (1, 2):
            for method in (1, 2, 3):
                results.append(run_cell(cell, drag, method))
                print(f"{cell.name} drag {drag} method {method}: "
                      f"{_summary(results[-1])}", file=sys.stderr, flush=True)
    print(markdown_table(results))
