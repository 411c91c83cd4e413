"""The gain of FMI 3.0's early return in the coupled system: which communication step for which
accuracy, with and without the floe's early return at its contact events.

    python build_fmu.py
    python benchmarks/coupling_early_return.py [--quick] [--fmus dist] [--no-fmu]
                                               [--out benchmarks/results]

The two scenes of ``benchmarks/coupling.py`` (quadratic drag, u = 0.3 m/s, 6 s): an impacting
floe (M = 1200 kg, e = 0.7) and a heavy floe that rides on the structure and separates (M = 4800
kg, e = 0.3), on a structure equal to IceImpact's built-in one (m = 1600 kg, c = 200 N.s/m, k =
1e6 N/m). Reference: IceImpact's own monolithic run (``structure.model = 1``), sampled at the
communication points, its impacts located exactly.

Masters (``examples/system/early_return.py``; Gauss-Seidel, floe first, second order: the
structure's acceleration is passed):

- **plain**: no early return (the FMI 2.0 loop of ``system.fmpy_master`` on the FMI 3.0 FMUs);
- **early**: the floe returns at each contact event, the structure is stepped to it (an impact's
  impulse as a kick of ``KICK`` seconds at the impact), the values are exchanged;
- **early+approach**: as early, and an event more than ``2 APPROACH`` after the step start is
  approached again from the step start (the floe's state restored) to ``APPROACH`` before it.

Each master runs through the FMUs (IceImpact3.fmu and ModalStructure3.fmu in FMPy, **via FMPy**)
and through the core (**via core**: :class:`iceimpact.Simulator` with ``stop_at_event`` and the
independent exact oscillator ``ExactSdof`` of ``tests/coupling_master.py``, the same master
written again over them): the column *FMU vs core* is the largest difference of the structure's
displacement between the two, relative to the monolithic peak.

Per row (the first three as ``benchmarks/coupling.py``'s ``measure``):

- **peak x error**: ``|max |x_c| - max |x_m|| / max |x_m|``;
- **x error**: ``max |x_c - x_m| / max |x_m|`` at the grid points (phase errors included);
- **impulse/s error**: relative error of the contact impulse delivered to the structure;
- **impact times, in order**: against the monolithic run's impacts with its Zeno sequences
  closed at the chatter time, as IceImpact closes them against an external structure
  (:func:`impacts_as_external`; the monolithic run follows them to their end), the coupled run's
  impacts matched to the reference's in order (the
  i-th with the i-th), max ``|t_c - t_m|`` over the matched ones; the plain master knows only the
  last impact of a step with several (the others are left out: *timed* counts the matched
  ones). One impact more or less shifts every later pair, so this column is large whenever the
  counts differ;
- **the same, without impacts at a step start**: the early masters exchange values at the very
  instant the ice separates from the structure, and the floe may then meet the structure it has
  just left at a relative velocity of rounding size (1e-9 m/s and less, against 4.5e-4 m/s for
  the smallest impact of the reference), which it counts as an impact at the start of its next
  step; this column leaves those out;
- **leading impacts**: how many of the first impacts (those at a step start left out), in order,
  are within ``LEAD`` (1 ms) of the reference's: how far into the sequence of impacts the coupled
  run follows the reference;
- **impacts**: coupled (of which at a step start) / monolithic counts (the latter with its Zeno
  sequences closed at the chatter time, as above);
- **doSteps**: the floe's and the structure's doStep calls (rolled-back ones included);
- **wall**: seconds for the coupled run in this process (FMU rows include the instantiation).

Two small tables follow for the impacting scene through the FMUs: the effect of the kick's length
(early master) and of the approach length (early+approach master).

Writes ``coupling_early_return.json`` (also the Hausdorff distance of the impact times,
``impact_dt_nearest``) and ``coupling_early_return.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
from coupling import SCENES, T_END, ice_values, impacts_as_external, measure
from tree import ROOT, load

from iceimpact import Scene
from iceimpact.simulator import Simulator, run

# after coupling, which loaded examples/system/system.py, the module early_return imports
early_return = load("examples/system/early_return.py")
APPROACH, KICK, MASTERS = early_return.APPROACH, early_return.KICK, early_return.MASTERS
early_return_master = early_return.early_return_master
ExactSdof = load("tests/coupling_master.py").ExactSdof

STEPS = (1e-2, 3e-3, 1e-3, 3e-4, 1e-4)
#: The leading impacts column counts the first impacts within this time of the reference's, s.
LEAD = 1e-3
QUICK_STEPS = (1e-2, 1e-3)
#: The kick lengths and approach lengths of the two small tables, and their steps.
KICKS, KICK_STEPS = (1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4), (3e-3, 1e-3)
APPROACHES, APPROACH_STEPS = (3e-5, 1e-4, 3e-4, 1e-3), (1e-2, 3e-3)


def core_master(scene: Scene, t_end: float, h: float, master: str = "early",
                kick: float = KICK, approach: float = APPROACH) -> dict:
    """The master of ``early_return.early_return_master`` over the core: a Simulator in
    external-structure mode (Gauss-Seidel) and an :class:`ExactSdof` for the structure. Each
    step is the same arithmetic as the FMUs' (the FMU's early step ends at ``t + (point - t)``,
    its plain step is ``advance(h)``), so the two differ by the structures' rounding only."""
    if master not in MASTERS:
        raise ValueError(f"master {master!r}: one of {MASTERS}")
    early_return_on = master != "plain"
    approaching = master == "early+approach"
    sim = Simulator(scene.replace(structure_model=2, coupling_scheme=1), record_impacts=False)
    st = ExactSdof(scene.structure_m, scene.structure_c, scene.structure_k)
    force = 0.0  # the structure's force input: the floe's coupling.force
    n = round(t_end / h)
    xs, impacts, at_start, impulse, count, t = [st.x], [], [], 0.0, 0, 0.0
    steps = {"floe": 0, "structure": 0}
    for k in range(n):
        point = (k + 1) * h
        while True:
            inputs = (st.x, st.v, st.acceleration(force))
            if not early_return_on:
                t_start = k * h
                report = sim.advance(h, structure=inputs)
                steps["floe"] += 1
                early, reached, at_point = False, t_start + h, True
            else:
                t_start = t
                saved = sim.save() if approaching else None
                end = t_start + (point - t_start)
                report = sim.advance_to(end, structure=inputs, stop_at_event=True)
                steps["floe"] += 1
                early = report.t != end
                reached = report.t if early else end
                if early and approaching and reached - t_start > 2.0 * approach:
                    sim.restore(saved)
                    end = t_start + (reached - approach - t_start)
                    report = sim.advance_to(end, structure=inputs, stop_at_event=True)
                    steps["floe"] += 1
                    early = report.t != end
                    reached = report.t if early else end
                    at_point = False
                else:
                    at_point = not early
            impulse += report.impulse
            force = report.coupling_force
            new_count = report.impact_count
            if new_count > count:
                impacts += [math.nan] * (new_count - count - 1) + [report.t_last]
                at_start += [False] * (new_count - count - 1) + [report.t_last == t_start]
            step = reached - t_start
            if early and new_count > count and report.t_last == reached and step > 2.0 * kick:
                t_kick = reached - kick
                st.step(t_kick - t_start, 0.0)
                st.step(reached - t_kick, report.impulse / (reached - t_kick))
                steps["structure"] += 2
            else:
                st.step(step, force)
                steps["structure"] += 1
            count = new_count
            if at_point:
                t = point
                break
            t = reached
        xs.append(st.x)
    return {"time": np.arange(n + 1) * h, "x": np.array(xs), "impulse": impulse, "count": count,
            "impacts": np.array(impacts), "at_start": np.array(at_start, dtype=bool),
            "steps": steps}


def impact_errors(impacts: np.ndarray, at_start: np.ndarray, reference: np.ndarray) -> dict:
    """The impact-time errors of a coupled run against the reference's impact times (see the
    module docstring): in order (max |dt|, and how many pairs had a known time), the same with
    the impacts at a step's start left out, the leading impacts within LEAD of those (an impact
    of unknown time ends the lead), and nearest (the Hausdorff distance of the known times)."""
    reference = np.asarray(reference, dtype=float)
    in_order, timed = early_return.impact_time_error(impacts, reference)
    real = np.asarray(impacts, dtype=float)[~np.asarray(at_start, dtype=bool)]
    in_order_real, timed_real = early_return.impact_time_error(real, reference)
    m = min(len(real), len(reference))
    off = np.flatnonzero(~(np.abs(real[:m] - reference[:m]) <= LEAD))
    leading = int(off[0]) if len(off) else m
    known = np.asarray(impacts, dtype=float)
    known = known[~np.isnan(known)]
    if len(known) and len(reference):
        distance = np.abs(known[:, None] - reference[None, :])
        nearest = float(max(distance.min(axis=1).max(), distance.min(axis=0).max()))
    else:
        nearest = math.nan
    return {"impact_dt_in_order": in_order, "impacts_timed": timed,
            "impact_dt_in_order_real": in_order_real, "impacts_timed_real": timed_real,
            "leading_impacts": leading, "impacts_at_start": int(np.sum(at_start)),
            "impact_dt_nearest": nearest}


def fmu_run(fmus: Path, scene: Scene, h: float, master: str, **options) -> dict:
    return early_return_master(fmus, T_END, h, master, ice=ice_values(scene),
                               flow_u=scene.flow_u, **options)


def row_of(coupled: dict, mono, wall: float, impacts: np.ndarray) -> dict:
    """A row's figures: x and impulse against the monolithic run ``mono``, impact times against
    ``impacts`` (:func:`impacts_as_external`)."""
    return {**measure(coupled, mono, wall),
            **impact_errors(coupled["impacts"], coupled["at_start"], impacts),
            "impacts_mono": len(impacts),
            "steps_floe": coupled["steps"]["floe"],
            "steps_structure": coupled["steps"]["structure"]}


def _dt(value: float) -> str:
    return "-" if math.isnan(value) else f"{value * 1e3:.3g} ms"


def _count(row: dict) -> str:
    at_start = f" ({row['impacts_at_start']})" if row["impacts_at_start"] else ""
    return f"{row['impacts']}{at_start} / {row['impacts_mono']}"


def _gap(value: float | None) -> str:
    return "" if value is None else f"{value:.1e}"


def attempt(function, *args, **kwargs) -> tuple[dict | None, str | None, float]:
    """(result, None, wall) of a coupled run, or (None, why it failed, wall): a run that a
    component refuses is a row that says so, not the end of the benchmark."""
    start = time.perf_counter()
    try:
        result = function(*args, **kwargs)
    except Exception as exc:  # an FMU's refused step (FMPy raises) or the core's exception
        return None, f"{type(exc).__name__}: {exc}", time.perf_counter() - start
    return result, None, time.perf_counter() - start


HEADER = ["| scene | master | via | h (ms) | peak x error | x error | impulse/s error | "
          "impact times, in order (timed) | the same, without impacts at a step start | "
          "leading impacts | impacts: coupled (at a step start) / mono | "
          "doSteps (floe + structure) | wall (s) | FMU vs core |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]


def line_of(row: dict) -> str:
    head = f"| {row['scene']} | {row['master']} | {row['via']} | {row['h'] * 1e3:g} | "
    if "failed" in row:
        return head + f"failed: {row['failed']} |" + " |" * 9
    return (head + f"{row['peak_error']:.2%} | {row['x_error']:.2%} | "
            f"{row['impulse_error']:.2%} | "
            f"{_dt(row['impact_dt_in_order'])} ({row['impacts_timed']}) | "
            f"{_dt(row['impact_dt_in_order_real'])} ({row['impacts_timed_real']}) | "
            f"{row['leading_impacts']} | {_count(row)} | "
            f"{row['steps_floe']} + {row['steps_structure']} | {row['wall']:.2f} | "
            f"{_gap(row.get('fmu_vs_core'))} |")


def sweep(fmus: Path, scene: Scene, name: str, master: str, option: str, values, steps,
          lines: list[str]) -> list[dict]:
    """The impacting scene through the FMUs with ``option`` (kick or approach) at each value."""
    rows = []
    for h in steps:
        mono = run(scene, T_END, dt=h)
        impacts = impacts_as_external(scene, h)
        for value in values:
            coupled, failed, wall = attempt(fmu_run, fmus, scene, h, master, **{option: value})
            row = {"scene": name, "master": master, "h": h, option: value}
            head = f"| {master} | {h * 1e3:g} | {value:g} | "
            if failed:
                row["failed"] = failed
                line = head + f"failed: {failed} |" + " |" * 6
            else:
                row.update(row_of(coupled, mono, wall, impacts))
                line = head + (f"{row['x_error']:.3%} | {row['impulse_error']:.3%} | "
                               f"{_dt(row['impact_dt_in_order'])} | "
                               f"{_dt(row['impact_dt_in_order_real'])} | "
                               f"{row['leading_impacts']} | {_count(row)} | "
                               f"{row['steps_floe']} + {row['steps_structure']} |")
            rows.append(row)
            lines.append(line)
            print(line, flush=True)
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="h = 10 ms and 1 ms only, no kick or approach tables")
    parser.add_argument("--fmus", type=Path, default=ROOT / "dist",
                        help="folder with IceImpact3.fmu and ModalStructure3.fmu")
    parser.add_argument("--no-fmu", action="store_true", help="the core masters only")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    steps = QUICK_STEPS if args.quick else STEPS
    vias = ["core"] if args.no_fmu else ["FMPy", "core"]
    rows: list[dict] = []
    lines = list(HEADER)
    print("\n".join(HEADER), flush=True)
    for name, values in SCENES.items():
        scene = Scene(**values)
        for h in steps:
            mono = run(scene, T_END, dt=h)
            impacts = impacts_as_external(scene, h)
            peak = float(np.max(np.abs(mono.x)))
            for master in MASTERS:
                runs = {}
                for via in vias:
                    if via == "FMPy":
                        coupled, failed, wall = attempt(fmu_run, args.fmus, scene, h, master)
                    else:
                        coupled, failed, wall = attempt(core_master, scene, T_END, h, master)
                    row = {"scene": name, "master": master, "via": via, "h": h}
                    if failed:
                        row["failed"] = failed
                    else:
                        runs[via] = coupled
                        row.update(row_of(coupled, mono, wall, impacts))
                        if via == "core" and "FMPy" in runs:
                            row["fmu_vs_core"] = float(np.max(np.abs(
                                runs["FMPy"]["x"] - coupled["x"])) / peak)
                    rows.append(row)
                    lines.append(line_of(row))
                    print(lines[-1], flush=True)
    tables = {}
    if not (args.quick or args.no_fmu):
        name, values = next(iter(SCENES.items()))
        scene = Scene(**values)
        for option, master, values_, steps_ in (("kick", "early", KICKS, KICK_STEPS),
                                                ("approach", "early+approach", APPROACHES,
                                                 APPROACH_STEPS)):
            sub = [f"\n{name}, through the FMUs: the {option} length\n",
                   f"| master | h (ms) | {option} (s) | x error | impulse/s error | "
                   "impact times, in order | the same, without impacts at a step start | "
                   "leading impacts | impacts | doSteps |",
                   "|---|---|---|---|---|---|---|---|---|---|"]
            print("\n".join(sub), flush=True)
            tables[option] = sweep(args.fmus, scene, name, master, option, values_, steps_, sub)
            lines += sub
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "coupling_early_return.json").write_text(json.dumps(
        {"t_end": T_END, "kick": KICK, "approach": APPROACH, "lead": LEAD, "rows": rows,
         **tables}, indent=1) + "\n")
    (args.out / "coupling_early_return.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
