"""CPU time per simulated second of method 3 against the stiffest rate it integrates.

    python tools/ode_rate_cost.py                      # RK45, DOP853 at 1e5, 3e5 1/s
    python tools/ode_rate_cost.py --ode 3 --rates 9.9e5

Four stiff scene kinds (docs/robustness.md, "Limits from the numerics"), the flow reversed at
every 1 ms step: an over-damped structure in flight (c / m = rate, the ice 1 m away, no drag),
the same structure pushed by a 1 g floe in contact (c / m = rate), a 1 g floe under a linear
drag b / M = rate (Figure 2 structure) and a 0.1 mg floe under a quadratic drag 2 B |u| / M =
rate. Each runs up to 1 s or a budget of CPU time; printed: CPU seconds per simulated second
and K = that / rate, the constant the limit ODE_EXPLICIT_RATE_MAX is derived from. A scene the
validation refuses is printed as refused.
"""

from __future__ import annotations

import argparse
import time

from iceimpact import ParameterError, Scene, Simulator

KINDS = ("over-damped flight", "over-damped stuck", "linear drag", "quadratic drag")


def scene(kind: str, rate: float, ode_method: int) -> Scene:
    """The scene of ``kind`` whose stiffest integrated rate is ``rate`` (1/s)."""
    common = dict(solver_method=3, solver_ode_method=ode_method)
    if kind == "over-damped flight":
        return Scene(structure_m=1.0, structure_k=1e8, structure_c=rate, structure_x0=0.01,
                     ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, **common)
    if kind == "over-damped stuck":
        return Scene(structure_m=1.0, structure_k=1e8, structure_c=rate, structure_x0=0.0,
                     structure_v0=0.0, ice_M=1e-3, ice_z0=0.0, ice_v0=0.0, **common)
    if kind == "linear drag":
        return Scene(ice_M=1e-3, ice_A=1.0, ice_Cd=1.0, drag_model=1,
                     drag_v_lin=rate * 1e-3 / 499.5, **common)
    # quadratic: B = 0.4995 kg/m, the flow speed giving 2 B |u| / M = rate
    return Scene(ice_M=1e-4, ice_A=1e-3, ice_Cd=1.0, drag_model=2, ice_v0=0.0,
                 flow_u=rate * 1e-4 / (2.0 * 0.4995), **common)


def cost(sc: Scene, budget: float, h: float = 1e-3) -> tuple[float, float]:
    """(CPU s per simulated s, simulated time reached) with the flow reversed every step."""
    sim = Simulator(sc)
    start = time.process_time()
    i = 0
    while sim.t < 1.0 - 1e-12 and time.process_time() - start < budget:
        sim.advance(h, sc.flow_u if i % 2 == 0 else -sc.flow_u)
        i += 1
    return (time.process_time() - start) / sim.t, sim.t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ode", default="1,2", help="solver.ode_method values, comma-separated")
    parser.add_argument("--rates", default="1e5,3e5", help="rates (1/s), comma-separated")
    parser.add_argument("--budget", type=float, default=4.0, help="CPU s per run")
    args = parser.parse_args()
    print("| scene | solver.ode_method | rate (1/s) | CPU s per simulated s | K (s) |")
    print("|---|---|---|---|---|")
    for kind in KINDS:
        for ode in (int(x) for x in args.ode.split(",")):
            for rate in (float(x) for x in args.rates.split(",")):
                try:
                    sc = scene(kind, rate, ode)
                except ParameterError as exc:
                    print(f"| {kind} | {ode} | {rate:.3g} | refused: {str(exc)[:60]}... | |")
                    continue
                per_second, reached = cost(sc, args.budget)
                print(f"| {kind} | {ode} | {rate:.3g} | {per_second:.2f} (over {reached:.3g} s) "
                      f"| {per_second / rate:.2g} |", flush=True)


if __name__ == "__main__":
    main()
