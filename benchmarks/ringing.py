"""Cost of method 1's stiff ringing scenes (docs/robustness.md, "exact tangent ringing"): this
tree against a base commit, side by side in one run.

The base commit's ``fmu_src`` is extracted with ``git archive`` into a temporary directory; each
case runs in a subprocess (this script with ``--worker``, ``PYTHONPATH`` that tree's ``fmu_src``)
importing ``iceimpact`` from either tree. Times are the CPU time of the measuring process
(``time.process_time``; the machine may be shared), each run stopped after ``--limit`` s of CPU
(a SIGPROF timer), so a run that does not finish reports how far it got. Cases, each a 1 s run:

- ``tangent ringing, u = 0``: an undamped structure (omega_n 4.1e7 rad/s, m = M = 1600 kg)
  released from rest at -0.16 m, the ice at rest exactly at the lowest point of its swing, no
  drag, e = 1, 10 ms steps. The exact motion has no impact (x = x0 cos(omega_n t));
- ``tangent ringing, no drag, u = 0.1``: the same with a flow, which without drag does not move
  the ice;
- ``stiff pair ringing in contact``: the random search's scene (m = 3537 kg, k = 1.06e19 N/m,
  c = 0, M = 3619 kg, linear drag, u = 6478 m/s, bodies together at -0.57 m/s), 0.37 s steps
  with the flow reversing at every step;
- ``drifting at W m/s, omega_n O``: the tangent ringing's structure (omega_n 4.1e7 or 4.1e5
  rad/s), the ice coasting at W (no drag) from W / 2 s below the lowest point of its swing,
  which it reaches at 0.5 s: the first impact is at the first trough after that (the exact one
  in 60-digit decimal arithmetic is in ``tests/solvers/exact/test_flight.py``), after up to 1e7
  periods at the bottom of the envelope;
- ``at rest 1e-15 m below, linear drag, u = 1e-6``: the ice pushed there by a weak flow;
- ``stopping 5e-16 m short``: the ice coasting in at 1.6e-17 m/s under a linear drag and no
  flow, which stops it short of the structure's lowest point: no impact ever.

Reported per case and tree: the simulated time reached, the CPU time, impacts, the first
impact's time, the evaluations of a flight's gap (value, slope, curvature and bounds: each
root-search iteration makes one, the drifting ice's period search a few per period it
bisects), root-search iterations of the last segment, the smallest gap at the communication
points and the smallest contact impulse of a step.

    python benchmarks/ringing.py                    # base 29ed3b0, limit 10 s
    python benchmarks/ringing.py --base HEAD~4 --limit 5

Prints a table and writes ``benchmarks/results/ringing.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tree import ROOT, extract_commit

BASE = "29ed3b0"
T_END = 1.0

OMEGA, X0 = 4.1e7, -0.16
TANGENT = dict(structure_m=1600.0, structure_k=1600.0 * OMEGA ** 2, structure_c=0.0,
               structure_x0=X0, structure_v0=0.0, ice_M=1600.0, ice_Cd=0.0, ice_z0=X0,
               ice_v0=0.0, impact_e=1.0, solver_method=1)
PAIR = dict(structure_m=3537.1073490753306, structure_c=0.0,
            structure_k=1.0599269884926448e+19, structure_x0=0.0,
            structure_v0=-0.5706191297623756, ice_M=3619.4971632535407,
            ice_A=1.282686929497336, ice_Cd=1.0689804569440564, ice_z0=0.0,
            ice_v0=-0.5706191297623756, impact_e=0.0, drag_model=1,
            drag_v_lin=1.282686929497336, flow_u=6478.176589776202, solver_method=1)
#: linear drag on the ice (drag.b = 49.95 kg/s with the defaults: b / M = 0.03121875 1/s)
LINEAR = dict(ice_Cd=1.0, drag_model=1)


def _drifting(speed: float, omega: float) -> dict:
    return {**TANGENT, "structure_k": 1600.0 * omega ** 2, "ice_z0": X0 - 0.5 * speed,
            "ice_v0": speed, "flow_u": 0.0}


#: name: (scene, communication step (s), flow reverses at every step)
CASES = {
    "tangent ringing, u = 0": ({**TANGENT, "flow_u": 0.0}, 0.01, False),
    "tangent ringing, no drag, u = 0.1": ({**TANGENT, "flow_u": 0.1}, 0.01, False),
    "stiff pair ringing in contact": (PAIR, 0.37, True),
    "drifting at 1e-9 m/s, omega_n 4.1e7": (_drifting(1e-9, OMEGA), 0.01, False),
    "drifting at 1e-13 m/s, omega_n 4.1e7": (_drifting(1e-13, OMEGA), 0.01, False),
    "drifting at 1e-15 m/s, omega_n 4.1e7": (_drifting(1e-15, OMEGA), 0.01, False),
    "drifting at 1e-15 m/s, omega_n 4.1e5": (_drifting(1e-15, 4.1e5), 0.01, False),
    "at rest 1e-15 m below, linear drag, u = 1e-6": (
        {**TANGENT, **LINEAR, "ice_z0": X0 - 1e-15, "flow_u": 1e-6}, 0.01, False),
    "stopping 5e-16 m short": ({**TANGENT, **LINEAR, "ice_z0": X0 - 1e-15,
                                "ice_v0": 5e-16 * (49.95 / 1600.0), "flow_u": 0.0},
                               0.01, False),
}


class _Stop(Exception):
    pass


def _stop(signum, frame):
    raise _Stop


def _worker(limit: float) -> dict:
    """The cases, with ``iceimpact`` from the tree on ``PYTHONPATH`` (a subprocess)."""
    import signal

    from iceimpact import Scene, Simulator
    from iceimpact.solvers.exact import Flight

    probes = [0]
    probe = Flight.probe

    def counted(self, tau):
        probes[0] += 1
        return probe(self, tau)
    Flight.probe = counted
    signal.signal(signal.SIGPROF, _stop)
    out = {}
    for name, (kw, h, reversing) in CASES.items():
        scene = Scene(**kw)
        sim = Simulator(scene)
        probes[0] = 0
        u = scene.flow_u
        min_gap = min_impulse = float("inf")
        start = time.process_time()
        signal.setitimer(signal.ITIMER_PROF, limit)
        i = 0
        try:
            while sim.t < T_END - 1e-12:
                r = sim.advance(min(h, T_END - sim.t), -u if reversing and i % 2 else u)
                i += 1
                state = sim.solver.state
                min_gap = min(min_gap, state.x - state.z)
                min_impulse = min(min_impulse, r.impulse)
        except _Stop:
            pass
        finally:
            signal.setitimer(signal.ITIMER_PROF, 0.0)
        cpu = time.process_time() - start
        search = getattr(sim.solver.seg, "search", None)
        out[name] = {"t": sim.t, "cpu_s": cpu, "finished": sim.t >= T_END - 1e-12,
                     "impacts": sim.impact_count,
                     "first_impact_s": sim.impacts[0].t if sim.impacts else None,
                     "probes": probes[0],
                     "iterations": search.iterations if search is not None else None,
                     "min_gap_m": min_gap, "min_impulse_Ns": min_impulse}
    return out


def _run(src: Path, limit: float) -> dict:
    res = subprocess.run([sys.executable, __file__, "--worker", "--limit", str(limit)],
                         capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(src)})
    return json.loads(res.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default=BASE, help="commit to compare with")
    parser.add_argument("--limit", type=float, default=10.0, help="CPU s per run")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(_worker(args.limit)))
        return
    with tempfile.TemporaryDirectory() as tmp:
        base = _run(extract_commit(args.base, Path(tmp)) / "fmu_src", args.limit)
    current = _run(ROOT / "fmu_src", args.limit)
    print("| case | tree | simulated (s) | CPU (s) | impacts | first impact (s) | "
          "gap evaluations | search iterations | min gap (m) | min impulse (N.s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in CASES:
        for label, res in ((args.base, base[name]), ("this tree", current[name])):
            reached = f"{res['t']:.3g}" + ("" if res["finished"] else " (stopped)")
            first = res["first_impact_s"]
            first = "-" if first is None else f"{first:.16g}"
            print(f"| {name} | {label} | {reached} | {res['cpu_s']:.2f} | {res['impacts']} | "
                  f"{first} | {res['probes']} | {res['iterations']} | {res['min_gap_m']:.3g} | "
                  f"{res['min_impulse_Ns']:.3g} |")
    result = {"base": args.base, "limit_cpu_s": args.limit, "t_end_s": T_END,
              "python": platform.python_version(), "machine": platform.machine(),
              "cases": {name: {"base": base[name], "current": current[name]}
                        for name in CASES}}
    out = ROOT / "benchmarks" / "results" / "ringing.json"
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
