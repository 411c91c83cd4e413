"""Reproduce the quadratic-drag figures of the article (Section 4.2) through IceImpact.fmu.

    python examples/reproduce_quadratic.py [--quick] [--only FIG] [--fmu dist/IceImpact.fmu]
                                           [--out out/reproduction] [--img-dir docs/img]

Every case runs through the FMU with FMPy, with the exact solver (``solver.method = 1``: the
closed-form quadratic-drag flight) and the article's fixed-step scheme (``solver.method = 2``:
explicit Euler for the ice, eq. 34-36, ``solver.dt = 1e-4`` s, gap-sign impact test); Figure 14
also with the literal tolerance window of eq. 26. Quadratic drag ``M z'' = -B |z' - u| (z' - u)``
(eq. 31-33, B = 499.5 kg/m for A = 1 m^2). 400 s per case, communication step 5 ms.

Figure groups (``--only`` takes a figure number or a group key):

* ``10``: free flight of the ice, linearised (eq. 6) against quadratic drag (eq. 3, exact and by
  eq. 34-36), at u = 0.1 m/s (a) and u = 1 m/s (b). The article gives neither the horizon nor
  the initial state nor the linearisation speed of (b): 200 s from z' = 0.01 m/s (the Figure 2
  start) and, at u = 1 m/s, both v_lin = u (the rule of eq. 30) and v_lin = 0.1 m/s.
* ``11``, ``12``: quadratic against linearised drag at a higher flow speed. The article says
  only "over 1 m/s"; Figure 11 is run at u = 1 m/s and Figure 12 at u = 2 m/s, the linearised
  runs with v_lin = u (eq. 30: the largest relative speed is the flow speed).
* ``13``: A = 2 m^2 at u = 0.1 m/s (Section 5 reads a lock-in, impact period T = 0.5 s, from
  Figure 13(b)); A = 1 m^2 (Figure 14) alongside.
* ``14-16``: the ice mass M = 1600 (Figure 14), 800 (Figure 15), 2400 kg (Figure 16).
* ``17-18``: the coefficient of restitution e = 0.1 (Figure 17) and 0.5 (Figure 18).

Writes one PNG per group and a JSON of every measure into ``--out`` (and a small copy of each
PNG into ``--img-dir``), and prints, per group, the numbers the article's text quotes next to
what each solver gives. Full run: about 2 minutes.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
from reproduce_common import (
    SOLVERS,
    Case,
    Group,
    Row,
    Run,
    decay_text,
    dominant_frequency,
    early_window,
    first_impact,
    fmt,
    impact_rate,
    impacts_between,
    late_window,
    main,
    max_deviation,
    mean_impact_interval,
    mean_impulse,
    median_impact_interval,
    mm,
    pass_through,
    peak,
    per_solver,
    secs,
    static_deflection,
    sticking_since,
    um,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

Runs = Mapping[str, Mapping[str, Run]]

QUADRATIC = {"drag.model": 2}

# Figure 10 ----------------------------------------------------------------------------------------
#: Free flight: the structure is this far downstream (m), so the ice never reaches it.
FAR = -1000.0
FREE_STEP = 0.05   # communication step of the free flights, s (no impacts to resolve)

FREE_FLIGHT_CASES = [
    Case("a_lin", "Figure 10(a)", "linear, u = 0.1, v_lin = 0.1",
         {"flow.u": 0.1, "ice.z0": FAR}, 200.0, ("exact",), FREE_STEP),
    Case("a_quad", "Figure 10(a)", "quadratic, u = 0.1",
         {"flow.u": 0.1, "ice.z0": FAR, **QUADRATIC}, 200.0, ("exact", "fixed"), FREE_STEP),
    Case("b_lin", "Figure 10(b)", "linear, u = 1, v_lin = 1",
         {"flow.u": 1.0, "drag.v_lin": 1.0, "ice.z0": FAR}, 200.0, ("exact",), FREE_STEP),
    Case("b_lin01", "Figure 10(b)", "linear, u = 1, v_lin = 0.1",
         {"flow.u": 1.0, "ice.z0": FAR}, 200.0, ("exact",), FREE_STEP),
    Case("b_quad", "Figure 10(b)", "quadratic, u = 1",
         {"flow.u": 1.0, "ice.z0": FAR, **QUADRATIC}, 200.0, ("exact", "fixed"), FREE_STEP),
]


def _drift(run: Run, t: float) -> float:
    """Distance (m) the ice has drifted from its start at time t (s)."""
    return float(np.interp(t, run.t, run.z) - run.z[0])


def _times(run: Run) -> list[float]:
    """Report times of Figure 10 within the run: 10, 50 and 200 s."""
    return [t for t in (10.0, 50.0, 200.0) if t <= run.t[-1] + 1e-9] or [float(run.t[-1])]


def report_free_flight(runs: Runs) -> list[Row]:
    """Figure 10: the linearised flight drifts away from the quadratic one as time passes, less
    so at high flow; the Euler steps (eq. 34-36) are close to the exact quadratic flight."""
    rows: list[Row] = []
    for part, u, lins in (("a", 0.1, (("a_lin", "v_lin = 0.1"),)),
                          ("b", 1.0, (("b_lin", "v_lin = 1"), ("b_lin01", "v_lin = 0.1")))):
        quad = runs[f"{part}_quad"]
        exact, euler = quad["exact"], quad["fixed"]
        ts = _times(exact)
        when = " / ".join(f"{t:g}" for t in ts)
        rows.append((f"u = {u:g}: quadratic drift z - z0 at {when} s (m)",
                     "Fig. 10: MathCad ODE solution of eq. 3" if part == "a" else "",
                     {"exact": " / ".join(f"{_drift(exact, t):.4g}" for t in ts),
                      "fixed": " / ".join(f"{_drift(euler, t):.4g}" for t in ts)}))
        for key, label in lins:
            lin = runs[key]["exact"]
            diff = [_drift(lin, t) - _drift(exact, t) for t in ts]
            rel = [100 * d / _drift(exact, t) for d, t in zip(diff, ts, strict=True)]
            article = ("'the difference grows as time goes by'" if part == "a" else
                       "'at high flow velocity the difference decreases'")
            rows.append((f"u = {u:g}: linear ({label}) - quadratic at {when} s (m)",
                         article if key in ("a_lin", "b_lin") else "",
                         {"exact": " / ".join(f"{d:.4g}" for d in diff)}))
            rows.append((f"u = {u:g}: same, relative to the drift (%)", "",
                         {"exact": " / ".join(f"{r:.1f}" for r in rel)}))
        err = [_drift(euler, t) - _drift(exact, t) for t in ts]
        rows.append((f"u = {u:g}: Euler eq. 34-36 - exact quadratic at {when} s (m)",
                     "Fig. 10(b): eq. 34-36 'close enough' at high flow" if part == "b" else "",
                     {"fixed": " / ".join(f"{e:.2g}" for e in err)}))
    return rows


def plot_free_flight(group: Group, runs: Runs) -> Figure:
    """Figure 10: drift z - z0 of the free ice (a: u = 0.1 m/s, b: u = 1 m/s) and the
    differences to the exact quadratic flight."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 2, figsize=(13, 10), squeeze=False)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.06, top=0.95, hspace=0.35, wspace=0.2)
    for j, (part, lins) in enumerate((("a", ("a_lin",)), ("b", ("b_lin", "b_lin01")))):
        quad = runs[f"{part}_quad"]
        ref = quad["exact"]
        ax_d, ax_lin, ax_eu = axes[:, j]
        drift = ref.z - ref.z[0]
        ax_d.plot(ref.t, drift, color="k", label="quadratic, exact (method 1)")
        euler = quad["fixed"]
        ax_d.plot(euler.t, euler.z - euler.z[0], "--", color="tab:orange",
                  label=f"quadratic, Euler eq. 34-36 (dt = {euler.scene.solver_dt:g} s)")
        # orange is the Euler flight's colour
        for key, color in zip(lins, ("tab:blue", "tab:green"), strict=False):
            lin = runs[key]["exact"]
            label = next(c.label for c in group.cases if c.key == key)
            ax_d.plot(lin.t, lin.z - lin.z[0], color=color, label=label)
            ax_lin.plot(lin.t, (lin.z - lin.z[0]) - drift, color=color,
                        label=f"{label} - quadratic")
        ax_eu.plot(euler.t, (euler.z - euler.z[0]) - drift, color="tab:orange")
        title = next(c.figure for c in group.cases if c.key == f"{part}_quad")
        ax_d.set(title=f"{title}: free ice, u = {ref.scene.flow_u:g} m/s",
                 ylabel="z - z0 (m)")
        ax_d.legend(fontsize=8)
        ax_lin.set(ylabel="linear - quadratic (m)", title="linearised minus quadratic drift")
        ax_lin.legend(fontsize=8)
        ax_eu.set(ylabel="Euler - exact (m)", xlabel="time (s)",
                  title="Euler steps (eq. 34-36) minus the exact quadratic flight")
    return fig


# Figures 11 and 12 --------------------------------------------------------------------------------
def flow_cases(figure: int, u: float) -> list[Case]:
    """Figure 11 or 12: the Figure 2 scene at flow speed u (m/s), quadratic and linearised
    (v_lin = u, the rule of eq. 30) drag."""
    return [Case(f"quad{u:g}", f"Figure {figure}", f"quadratic, u = {u:g} m/s",
                 {"flow.u": u, **QUADRATIC}),
            Case(f"lin{u:g}", f"Figure {figure}", f"linear, u = {u:g}, v_lin = {u:g}",
                 {"flow.u": u, "drag.v_lin": u})]


def _frequencies(run: Run) -> str:
    """Dominant frequency of x (Hz) over the first 50 s and over the last 20 s."""
    early = dominant_frequency(run, *early_window(run))
    late = dominant_frequency(run, *late_window(run))
    return f"{fmt(early, '.2f')} / {fmt(late, '.2f')}"


def _sticking_frequency(run: Run) -> str:
    """sqrt(k / (m + M)) / 2 pi, Hz: both bodies moving together."""
    sc = run.scene
    return f"{math.sqrt(sc.structure_k / (sc.structure_m + sc.ice_M)) / (2 * math.pi):.2f}"


def report_flow(u: float, figure: int) -> Callable[[Runs], list[Row]]:
    """The table of Figure 11 or 12."""

    def report(runs: Runs) -> list[Row]:
        q, lin = runs[f"quad{u:g}"], runs[f"lin{u:g}"]
        rows: list[Row] = []
        for name, r in (("quadratic", q), ("linear", lin)):
            first = name == "quadratic"
            rows += [
                (f"{name}: peak |x| (mm)",
                 "linear 'follows the quadratic drag force model in the beginning'"
                 if first else "", per_solver(r, lambda x: mm(peak(x)[0]))),
                (f"{name}: impacts in 0-10 s", "",
                 per_solver(r, lambda x: str(impacts_between(x, 0.0, min(10.0, x.t[-1]))))),
                (f"{name}: vibration < 10 % of peak after (s)",
                 "quadratic 'approaches steady-state vibration more quickly'" if first else "",
                 per_solver(r, lambda x: decay_text(x, 0.1))),
                (f"{name}: sticking / pinned from (s)", "",
                 per_solver(r, lambda x: secs(sticking_since(x)))),
                (f"{name}: max |x - x_s|, last 20 s (um)",
                 ("Fig. 12: quadratic 'steady-state vibration'" if first else
                  "Fig. 12: linear 'no steady-state vibration until 400 s'")
                 if figure == 12 else "",
                 per_solver(r, lambda x: um(max_deviation(x, *late_window(x))))),
                (f"{name}: dominant frequency 0-50 s / last 20 s (Hz)", "",
                 per_solver(r, _frequencies)),
                (f"{name}: impacts per s, last 20 s", "",
                 per_solver(r, lambda x: f"{impact_rate(x, *late_window(x)):.1f}")),
                (f"{name}: impacts in the whole run", "", per_solver(r, lambda x: str(x.impacts))),
            ]
        rows.append(("static deflection x_s = F / k (um)", "eq. 29",
                     {s: f"quad {um(static_deflection(q[s].scene))}, "
                         f"lin {um(static_deflection(lin[s].scene))}" for s in q}))
        return rows

    return report


# Figure 13 ---------------------------------------------------------------------------------------
AREA_CASES = [
    Case("a2", "Figure 13", "A = 2 m^2, u = 0.1", {"ice.A": 2.0, **QUADRATIC}),
    Case("a1", "Figure 14", "A = 1 m^2, u = 0.1", dict(QUADRATIC)),
]


def _windows(run: Run) -> list[tuple[float, float]]:
    """0-50 s, 50-100 s and the last 20 s, clipped to the run."""
    end = float(run.t[-1])
    spans = [(0.0, min(50.0, end))]
    if end >= 100.0:
        spans.append((50.0, 100.0))
    spans.append(late_window(run))
    return spans


def report_area(runs: Runs) -> list[Row]:
    """Figure 13 and Section 5: A = 2 m^2 settles as if driven by a faster flow; lock-in with
    T = 0.5 s, 2 pi / T = 12.57 rad/s = omega_n / 2."""
    a2, a1 = runs["a2"], runs["a1"]
    wn = next(iter(a2.values())).scene.omega_n

    def spans(func) -> dict[str, str]:
        return {s: " / ".join(fmt(func(r, t0, t1), ".3g") for t0, t1 in _windows(r))
                for s, r in a2.items()}

    some = next(iter(a2.values()))
    names = " / ".join(f"{t0:g}-{t1:g}" for t0, t1 in _windows(some))
    return [
        ("A = 2: vibration < 10 % of peak after (s)",
         "'quickly approach the steady-state vibrations'",
         per_solver(a2, lambda x: decay_text(x, 0.1))),
        ("A = 1: vibration < 10 % of peak after (s)", "",
         per_solver(a1, lambda x: decay_text(x, 0.1))),
        ("A = 2: sticking / pinned from (s)", "",
         per_solver(a2, lambda x: secs(sticking_since(x)))),
        ("A = 1: sticking / pinned from (s)", "",
         per_solver(a1, lambda x: secs(sticking_since(x)))),
        (f"A = 2: median impact interval, {names} s (s)", "T = 0.5 s (Section 5, Fig. 13(b))",
         spans(median_impact_interval)),
        (f"A = 2: mean impact interval, {names} s (s)", "",
         spans(mean_impact_interval)),
        (f"A = 2: dominant frequency of x, {names} s (Hz)",
         f"2 pi / T = 12.57 rad/s = 2.00 Hz = wn / 2 (wn = {wn:.0f} rad/s)",
         spans(dominant_frequency)),
        (f"A = 2: impacts per s, {names} s", "",
         spans(lambda r, t0, t1: impact_rate(r, t0, t1))),
        ("A = 2: peak |x| (mm)", "", per_solver(a2, lambda x: mm(peak(x)[0]))),
        ("A = 2: impacts in the whole run", "", per_solver(a2, lambda x: str(x.impacts))),
        ("sticking frequency sqrt(k / (m + M)) / 2 pi (Hz)", "-",
         per_solver(a2, _sticking_frequency)),
    ]


# Figures 14-16 -----------------------------------------------------------------------------------
MASS_CASES = [
    Case("m1600", "Figure 14", "M = 1600 kg", dict(QUADRATIC),
         solvers=("exact", "fixed", "window")),
    Case("m800", "Figure 15", "M = 800 kg", {"ice.M": 800.0, **QUADRATIC}),
    Case("m2400", "Figure 16", "M = 2400 kg", {"ice.M": 2400.0, **QUADRATIC}),
]


def report_mass(runs: Runs) -> list[Row]:
    """Figures 14-16: the role of the ice mass holds with quadratic drag; M = 2400 kg 'still
    unstable' (16(b)) while M = 800 kg is in steady-state vibration (15(b))."""
    rows: list[Row] = []
    claims = {
        "m800": ("Fig. 15(b): M = 800 'in the steady-state vibration'",
                 "heavier: 'impacts happen less frequently but with larger magnitudes'"),
        "m1600": ("", ""),
        "m2400": ("Fig. 16(b): M = 2400 'still unstable'", ""),
    }
    for key in ("m800", "m1600", "m2400"):
        r = runs[key]
        label = f"M = {key[1:]}"
        claim_decay, claim_impacts = claims[key]
        rows += [
            (f"{label}: impacts in 0-50 s", claim_impacts,
             per_solver(r, lambda x: str(impacts_between(x, *early_window(x))))),
            (f"{label}: mean impulse per impact, 0-50 s (N.s)", "",
             per_solver(r, lambda x: mean_impulse(x, *early_window(x)))),
            (f"{label}: peak |x| (mm)", "", per_solver(r, lambda x: mm(peak(x)[0]))),
            (f"{label}: vibration < 10 % of peak after (s)", claim_decay,
             per_solver(r, lambda x: decay_text(x, 0.1))),
            (f"{label}: sticking / pinned from (s)", "",
             per_solver(r, lambda x: secs(sticking_since(x)))),
            (f"{label}: max |x - x_s|, 50-100 s (um)", "",
             per_solver(r, lambda x: um(max_deviation(x, min(50.0, x.t[-1]),
                                                      min(100.0, x.t[-1]))))),
            (f"{label}: impacts in the whole run", "", per_solver(r, lambda x: str(x.impacts))),
        ]
    rows.append(("M = 1600: ice passes through the structure at (s)", "",
                 per_solver(runs["m1600"], lambda x: secs(pass_through(x)))))
    return rows


# Figures 17-18 -----------------------------------------------------------------------------------
RESTITUTION_CASES = [
    Case("e0.1", "Figure 17", "e = 0.1", {"impact.e": 0.1, **QUADRATIC}),
    Case("e0.5", "Figure 18", "e = 0.5", {"impact.e": 0.5, **QUADRATIC}),
]


def report_restitution(runs: Runs) -> list[Row]:
    """Figures 17-18: with e = 0.5 the system 'loses the momentum at approximately 43 s'
    (Figure 18(b)), against 54 s with linearised drag (Figure 8(b))."""
    a, b = runs["e0.1"], runs["e0.5"]

    def before_sticking(q: Run) -> str:
        t = sticking_since(q)
        return str(impacts_between(q, 0.0, t)) if t is not None else f"{q.impacts} (no stick)"

    return [
        ("e = 0.1: first impact (s)", "",
         per_solver(a, lambda q: secs(first_impact(q), "none"))),
        ("e = 0.1: impacts before sticking / pin", "", per_solver(a, before_sticking)),
        ("e = 0.1: sticking / pinned from (s)", "",
         per_solver(a, lambda q: secs(sticking_since(q)))),
        ("e = 0.1: vibration < 10 % of peak after (s)", "",
         per_solver(a, lambda q: decay_text(q, 0.1))),
        ("e = 0.5: vibration < 50 % of peak after (s)",
         "Fig. 18(b): 'loses the momentum at approximately 43 seconds'",
         per_solver(b, lambda q: decay_text(q, 0.5))),
        ("e = 0.5: vibration < 10 % of peak after (s)", "(linear drag, Fig. 8(b): 54 s)",
         per_solver(b, lambda q: decay_text(q, 0.1))),
        ("e = 0.5: sticking / pinned from (s)", "",
         per_solver(b, lambda q: secs(sticking_since(q)))),
        ("e = 0.5: impacts in the whole run", "", per_solver(b, lambda q: str(q.impacts))),
        ("e = 0.5: impacts per s, last 20 s", "",
         per_solver(b, lambda q: f"{impact_rate(q, *late_window(q)):.0f}")),
        ("peak |x| e = 0.1 / 0.5 (mm)", "'more sensitive to change in e' than linear drag",
         {s: " / ".join(mm(peak(q[s])[0]) for q in (a, b)) for s in b}),
        ("max |x - x_s| 5-50 s, e = 0.1 / 0.5 (mm)", "",
         {s: " / ".join(mm(max_deviation(q[s], min(5.0, float(q[s].t[-1])),
                                         early_window(q[s])[1])) for q in (a, b)) for s in b}),
    ]


GROUPS = [
    Group("10", (10,), "free flight of the ice: linearised against quadratic drag",
          "fig10_free_flight.png", FREE_FLIGHT_CASES, report_free_flight, plot_free_flight,
          notes=[f"the structure is {-FAR:g} m downstream: no impact; the fixed-step column is "
                 "the Euler flight of eq. 34-36"]),
    Group("11", (11,), "quadratic against linearised drag, u = 1 m/s",
          "fig11_flow_1.png", flow_cases(11, 1.0), report_flow(1.0, 11)),
    Group("12", (12,), "quadratic against linearised drag, u = 2 m/s",
          "fig12_flow_2.png", flow_cases(12, 2.0), report_flow(2.0, 12)),
    Group("13", (13,), "drag area A = 2 m^2, quadratic drag (and the lock-in of Section 5)",
          "fig13_area_2.png", AREA_CASES, report_area),
    Group("14-16", (14, 15, 16), "ice mass M = 1600 / 800 / 2400 kg, quadratic drag",
          "fig14-16_ice_mass_quadratic.png", MASS_CASES, report_mass),
    Group("17-18", (17, 18), "coefficient of restitution e = 0.1 / 0.5, quadratic drag",
          "fig17-18_restitution_quadratic.png", RESTITUTION_CASES, report_restitution,
          notes=["'vibration < q of peak after' is the last time the structure's amplitude "
                 "envelope sqrt((x - x_s)^2 + (v/wn)^2) reaches q times its maximum"]),
]

assert all(s in SOLVERS for g in GROUPS for c in g.cases for s in c.solvers)


def run_main(argv: list[str] | None = None) -> int:
    """Entry point (see the module docstring for the options)."""
    return main("quadratic", (__doc__ or "").splitlines()[0], GROUPS, argv)


if __name__ == "__main__":
    sys.exit(run_main())
