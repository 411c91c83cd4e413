"""Where the impact sequences of a reference commit and this tree part, and which one is right.

For each scene (default: the two of ``core_speed.py`` whose counts moved most) ``run(scene, 1000,
dt=1e-2)`` is run once with the reference commit's core (``--base``, extracted as in
``core_speed.py``) and once with this tree's, each in a fresh process, and the impact lists are
compared:

- **parting**: the first impact whose time differs by more than 1e-12, 1e-9, 1e-6 and 1e-3 s
  (index from 0, time), the growth of the difference per impact, the closing speeds and
  restitutions of the impacts up to the parting (a grazing impact? a chatter closing into
  sticking?);
- **an independent check**: ``tests/ode_reference.py`` (DOP853 with the gap as an event, no code
  shared with ``iceimpact``) run from t = 0 at rtol 1e-12 and 1e-13 over the impacts up to a
  little beyond the parting, and restarted at rtol 1e-13 from each of the two codes' post-impact
  states to its next impact (each flight's own error);
- **counts**: impacts over 100 s and 1,000 s and the time from which the bodies stick for good.

Writes ``benchmarks/results/count_divergence.json`` and ``.md``.

    python benchmarks/count_divergence.py                     # ~2 min
    python benchmarks/count_divergence.py --scenes figure2 --base 060a0a0
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from core_speed import DT, SCENES
from tree import ROOT, extract_commit, load

from iceimpact import Scene

ode_simulate = load("tests/ode_reference.py").simulate

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
T_END = 1000.0        # s, the long run
T_SHORT = 100.0       # s, the count also reported at this time
THRESHOLDS = (1e-12, 1e-9, 1e-6, 1e-3)   # s
BEYOND = 8            # impacts checked against the ODE beyond the parting

#: One run, its impact list and when the bodies stick for good; JSON on stdout.
_WORKER = """
import json, sys
from iceimpact import Scene, run
fields, t_end, dt = json.loads(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
res = run(Scene(**fields), t_end, dt=dt)
imp = res.impacts
print(json.dumps({"impacts": {name: imp[name].tolist() for name in imp.dtype.names},
                  "sticking_since": res.sticking_since}))
"""


def impacts_of(core: Path, fields: dict) -> dict:
    """The impact arrays and ``sticking_since`` of ``run(scene, T_END)`` with ``core``."""
    done = subprocess.run([sys.executable, "-c", _WORKER, json.dumps(fields), repr(T_END),
                           repr(DT)], capture_output=True, text=True,
                          env={"PYTHONPATH": str(core), "PATH": "/usr/bin:/bin"}, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{core}: {done.stderr}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    return {"impacts": {k: np.array(v) for k, v in out["impacts"].items()},
            "sticking_since": out["sticking_since"]}


def first_above(diff: np.ndarray, threshold: float) -> int | None:
    above = np.nonzero(diff > threshold)[0]
    return int(above[0]) if above.size else None


def flight_errors(scene: Scene, imp: dict, n: int) -> np.ndarray:
    """|next impact time| of DOP853 (rtol 1e-13) restarted from each of the first n post-impact
    states, minus the code's own next impact time, s (NaN where the ODE finds none)."""
    errors = np.full(n, np.nan)
    for i in range(n):
        if imp["restitution"][i] == 0.0:
            break  # the bodies stick: the ODE reference does not model that
        y0 = [imp["x"][i], imp["v_plus"][i], imp["x"][i], imp["w_plus"][i]]
        nxt = ode_simulate(scene, imp["t"][i] + 10.0, max_impacts=1, rtol=1e-13, atol=1e-16,
                           t0=imp["t"][i], y0=y0)["t"]
        if len(nxt):
            errors[i] = abs(nxt[0] - imp["t"][i + 1])
    return errors


def study(name: str, cores: dict[str, Path]) -> dict:
    fields = SCENES[name][0]
    scene = Scene(**fields)
    runs = {side: impacts_of(core, fields) for side, core in cores.items()}
    tb, ta = runs["before"]["impacts"]["t"], runs["after"]["impacts"]["t"]
    n = min(tb.size, ta.size)
    diff = np.abs(ta[:n] - tb[:n])
    parts = {f"{th:g}": first_above(diff, th) for th in THRESHOLDS}
    parting = parts[f"{THRESHOLDS[-1]:g}"]
    out: dict = {"scene": name, "fields": fields, "parting_index": parting,
                 "first_above": {th: {"index": i, "t_s": None if i is None else float(tb[i])}
                                 for th, i in parts.items()}}
    for side, r in runs.items():
        t = r["impacts"]["t"]
        out[side] = {"impacts_100s": int(np.sum(t <= T_SHORT)), "impacts_1000s": int(t.size),
                     "sticking_since_s": r["sticking_since"],
                     "plastic_impacts": int(np.sum(r["impacts"]["restitution"] == 0.0))}
    if parting is None:
        return out
    # the growth of the difference per impact, from where it leaves rounding to the parting
    start = first_above(diff, 1e-13) or 0
    if parting > start and diff[start] > 0:
        out["growth_per_impact"] = float((diff[parting] / diff[start]) ** (1 / (parting - start)))
    imp = runs["before"]["impacts"]
    closing = imp["w_minus"][:parting + 1] - imp["v_minus"][:parting + 1]
    out["up_to_parting"] = {"min_closing_m_per_s": float(closing.min()),
                            "restitutions": sorted({float(e) for e in
                                                    imp["restitution"][:parting + 1]}),
                            "t_parting_s": float(tb[parting])}
    # the independent check
    k = parting + BEYOND
    t_ode = {rtol: ode_simulate(scene, float(tb[min(k, n - 1)]) + 1.0, max_impacts=k,
                                rtol=rtol, atol=rtol * 1e-3)["t"] for rtol in (1e-12, 1e-13)}
    m = min(k, *(v.size for v in t_ode.values()))
    ode13, ode12 = t_ode[1e-13][:m], t_ode[1e-12][:m]
    rows = [{"index": i, "t_s": float(ode13[i]), "before_minus_ode13": float(tb[i] - ode13[i]),
             "after_minus_ode13": float(ta[i] - ode13[i]),
             "ode12_minus_ode13": float(ode12[i] - ode13[i]),
             "before_minus_after": float(tb[i] - ta[i])} for i in range(m)]
    out["ode"] = {"rows": rows,
                  "parting_from_ode13": {
                      "before": first_above(np.abs(tb[:m] - ode13), 1e-3),
                      "after": first_above(np.abs(ta[:m] - ode13), 1e-3),
                      "ode12": first_above(np.abs(ode12 - ode13), 1e-3)},
                  "flight_error_max_s": {
                      side: float(np.nanmax(flight_errors(scene, r["impacts"],
                                                          min(k, r["impacts"]["t"].size - 1))))
                      for side, r in runs.items()}}
    return out


def markdown(results: list[dict], base: str) -> str:
    lines = [f"Before: commit {base}; after: this tree. `run(scene, {T_END:g}, dt={DT:g})`; "
             "impact i counted from 0. ODE: tests/ode_reference.py, DOP853 with the gap as an "
             "event.", ""]
    for r in results:
        b, a = r["before"], r["after"]
        lines += [f"## {r['scene']}", "",
                  f"- impacts over {T_SHORT:g} s: {b['impacts_100s']} before, "
                  f"{a['impacts_100s']} after; over {T_END:g} s: {b['impacts_1000s']} and "
                  f"{a['impacts_1000s']}; the bodies stick for good from "
                  f"{b['sticking_since_s']} s and {a['sticking_since_s']} s "
                  f"({b['plastic_impacts']} and {a['plastic_impacts']} plastic impacts)",
                  "- first impact moved by more than: " + ", ".join(
                      f"{th} s at i = {v['index']} (t = {v['t_s']:.2f} s)"
                      if v["index"] is not None else f"{th} s: none"
                      for th, v in r["first_above"].items())]
        if "up_to_parting" in r:
            u = r["up_to_parting"]
            lines.append(f"- up to the parting: restitutions {u['restitutions']}, slowest "
                         f"closing speed {u['min_closing_m_per_s']:.1e} m/s; the difference "
                         f"grows by {r.get('growth_per_impact', float('nan')):.1f}x per impact")
        if "ode" in r:
            o = r["ode"]
            p = o["parting_from_ode13"]
            lines += [f"- parting (> 1e-3 s) from DOP853 at rtol 1e-13: before at i = "
                      f"{p['before']}, after at i = {p['after']}, DOP853 at rtol 1e-12 at i = "
                      f"{p['ode12']}",
                      "- each flight restarted from the code's post-impact state (DOP853, "
                      "rtol 1e-13): largest next-impact error "
                      f"{o['flight_error_max_s']['before']:.1e} s before, "
                      f"{o['flight_error_max_s']['after']:.1e} s after", "",
                      "| i | t (s) | before - ODE 1e-13 | after - ODE 1e-13 | ODE 1e-12 - ODE "
                      "1e-13 | before - after |", "|---:|---:|---:|---:|---:|---:|"]
            for row in o["rows"]:
                lines.append(f"| {row['index']} | {row['t_s']:.6f} | "
                             f"{row['before_minus_ode13']:+.1e} | {row['after_minus_ode13']:+.1e}"
                             f" | {row['ode12_minus_ode13']:+.1e} | "
                             f"{row['before_minus_after']:+.1e} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="060a0a0", help="reference commit (before)")
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES),
                        default=["quadratic_A2", "heavy_floe"])
    parser.add_argument("--out", type=Path, default=RESULTS / "count_divergence.json")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="count_divergence_") as tmp:
        cores = {"before": extract_commit(args.base, Path(tmp)) / "fmu_src",
                 "after": ROOT / "fmu_src"}
        results = []
        for name in args.scenes:
            results.append(study(name, cores))
            print(markdown(results[-1:], args.base), flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "count_divergence", "base": args.base,
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "command": "python benchmarks/count_divergence.py " + " ".join(argv or sys.argv[1:]),
        "machine": platform.platform(), "t_end_s": T_END, "dt_s": DT, "scenes": results},
        indent=2) + "\n")
    args.out.with_suffix(".md").write_text(markdown(results, args.base))
    print(f"wrote {args.out} and {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
