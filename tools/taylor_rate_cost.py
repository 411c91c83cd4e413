"""CPU time and Taylor steps per simulated second of method 1's quadratic-drag sticking phase
against the rates it integrates.

    python tools/taylor_rate_cost.py                          # 1e4, 1e5, 3e5, 1e6 1/s
    python tools/taylor_rate_cost.py --rates 1e5 --budget 10

Three scene kinds (docs/robustness.md, "Limits from the numerics"), a 1 kg floe stuck from the
start on a 9 kg structure at rest at x = 0 (so m + M = 10 kg), the flow switched between 1 and
LOW_FLOW m/s at every 1 ms step (each switch re-anchors the sticking phase and starts a
transient; 0.5 m/s, but 1 m/s under the stiff drag, where a weaker flow pulls the floe off):
a stiff, lightly damped structure (sqrt(k / (m + M)) = rate, zeta 0.05), an over-damped one
(c / (m + M) = rate, sqrt(k / (m + M)) = rate / 20) and a soft one under a stiff drag
(2 B u / (m + M) = rate at u = 1 m/s). Each runs up to 1 s or a budget of CPU time; printed:
CPU seconds and Taylor steps per simulated second, and each divided by the rate (the constants
the method-1 limit TAYLOR_RATE_MAX is derived from). A scene the validation refuses is printed
as refused.
"""

from __future__ import annotations

import argparse
import time

from iceimpact import ParameterError, Scene, Simulator
from iceimpact.solvers.search import taylor

KINDS = ("stiff", "over-damped", "stiff drag")
#: masses (kg): the structure, the floe, together
M_STRUCTURE, M_ICE = 9.0, 1.0
TOTAL = M_STRUCTURE + M_ICE
#: the flow of every other step (m/s; 1 m/s at the others)
LOW_FLOW = {"stiff": 0.5, "over-damped": 0.5, "stiff drag": 1.0}


def scene(kind: str, rate: float, **overrides) -> Scene:
    """The scene of ``kind`` whose stiffest sticking rate is ``rate`` (1/s)."""
    drag_rate = 1e3 if kind != "stiff drag" else rate  # 2 B u / (m + M) at u = 1 m/s
    omega = {"stiff": rate, "over-damped": rate / 20.0, "stiff drag": 1e2}[kind]
    c = {"stiff": 0.1 * rate * TOTAL, "over-damped": rate * TOTAL, "stiff drag": 0.0}[kind]
    B = drag_rate * TOTAL / 2.0
    fields = dict(structure_m=M_STRUCTURE, structure_k=omega ** 2 * TOTAL, structure_c=c,
                  structure_x0=0.0, structure_v0=0.0, ice_M=M_ICE, ice_A=B / 499.5,
                  ice_Cd=1.0, ice_z0=0.0, ice_v0=0.0, drag_model=2, flow_u=1.0,
                  solver_method=1)
    fields.update(overrides)
    return Scene(**fields)


def cost(sc: Scene, low: float, budget: float, h: float = 1e-3) -> tuple[float, float, float]:
    """(CPU s per simulated s, Taylor steps per simulated s, simulated time reached) with the
    flow switched between flow.u and ``low`` at every step."""
    steps = [0]
    original, original_run = taylor.StickingTaylor.step, taylor.StickingTaylor.run

    def counted(self, *args, **kwargs):
        steps[0] += 1
        return original(self, *args, **kwargs)

    def counted_run(self, *args):  # (the steps of a compiled run)
        made = original_run(self, *args)
        steps[0] += len(made)
        return made

    taylor.StickingTaylor.step, taylor.StickingTaylor.run = counted, counted_run
    try:
        sim = Simulator(sc)
        start = time.process_time()
        i = 0
        while sim.t < 1.0 - 1e-12 and time.process_time() - start < budget:
            sim.advance(h, sc.flow_u if i % 2 == 0 else low)
            i += 1
        cpu = time.process_time() - start
    finally:
        taylor.StickingTaylor.step, taylor.StickingTaylor.run = original, original_run
    return cpu / sim.t, steps[0] / sim.t, sim.t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", default="1e4,1e5,3e5,1e6", help="rates (1/s), comma-separated")
    parser.add_argument("--budget", type=float, default=4.0, help="CPU s per run")
    args = parser.parse_args()
    print("| scene | rate (1/s) | CPU s per simulated s | K (s) | Taylor steps per simulated s "
          "| steps / rate |")
    print("|---|---|---|---|---|---|")
    for kind in KINDS:
        for rate in (float(x) for x in args.rates.split(",")):
            try:
                sc = scene(kind, rate)
            except ParameterError as exc:
                print(f"| {kind} | {rate:.3g} | refused: {str(exc)[:70]}... | | | |")
                continue
            per_second, steps, reached = cost(sc, LOW_FLOW[kind], args.budget)
            print(f"| {kind} | {rate:.3g} | {per_second:.2f} (over {reached:.3g} s) "
                  f"| {per_second / rate:.2g} | {steps:.3g} | {steps / rate:.3g} |", flush=True)


if __name__ == "__main__":
    main()
