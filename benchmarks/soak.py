"""Long runs: memory of one FMU instance over millions of steps, and the core over 10^5 impacts.

1. One IceImpact.fmu instance (FMPy ``FMU2Slave``) stepped N times (default 2 million, 1 ms
   steps: the Figure 2 scene over 2000 s) reading every output at each step, as a master
   would. The process's resident memory (VmRSS) is read after a warm-up and at checkpoints.
2. The core (``Simulator``) on the A = 2 m2 quadratic-drag scene with a flow that keeps
   reversing (0.5 m/s for 1.6 s, then -0.5 m/s for 0.4 s, so the ice never settles), until
   10^5 impacts: time per impact and traced memory per block of 10^4 impacts, to show both
   stay constant.

Prints tables, writes JSON (benchmarks/results/soak.json).

    python benchmarks/soak.py            # 2 million FMU steps, 10^5 impacts
    python benchmarks/soak.py --quick    # 200,000 steps, 2x10^4 impacts
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import shutil
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STEP = 1e-3  # s


def rss_mb() -> float:
    """Resident memory of this process, MB (Linux /proc)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def build_fmu(dest: Path) -> Path:
    spec = importlib.util.spec_from_file_location("build_fmu", ROOT / "build_fmu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build(dest)


def soak_fmu(n_steps: int, checkpoints: int = 10) -> dict:
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    tmp = Path(tempfile.mkdtemp(prefix="soak_"))
    try:
        fmu = build_fmu(tmp / "dist")
        md = read_model_description(str(fmu))
        refs = {v.name: v.valueReference for v in md.modelVariables}
        real_out = [refs[n] for n in ("structure.x", "structure.v", "ice.z", "ice.v",
                                      "contact.gap", "contact.impulse", "contact.force",
                                      "contact.t_last")]
        int_out = [refs["contact.count"]]
        bool_out = [refs["contact.active"]]
        unzip = extract(str(fmu), unzipdir=str(tmp / "unzipped"))
        slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip,
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName="soak")
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        t = 0.0
        warmup = min(10_000, n_steps // 10)
        rows = []
        mark = time.perf_counter()
        every = max(1, (n_steps - warmup) // checkpoints)
        for k in range(n_steps):
            slave.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            t += STEP
            slave.getReal(real_out)
            slave.getInteger(int_out)
            slave.getBoolean(bool_out)
            if k + 1 == warmup or (k + 1 > warmup and (k + 1 - warmup) % every == 0):
                now = time.perf_counter()
                rows.append({"steps": k + 1, "rss_mb": rss_mb(),
                             "us_per_step": (now - mark) / (every if rows else k + 1) * 1e6,
                             "impacts": slave.getInteger(int_out)[0]})
                mark = now
        slave.terminate()
        slave.freeInstance()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {"steps": n_steps, "checkpoints": rows,
            "rss_growth_mb": rows[-1]["rss_mb"] - rows[0]["rss_mb"]}


def soak_core(n_impacts: int, block: int = 10_000) -> dict:
    from iceimpact import Scene, Simulator

    sim = Simulator(Scene(ice_A=2.0, drag_model=2))
    tracemalloc.start()
    rows = []
    mark, done, k = time.perf_counter(), 0, 0
    while len(sim.impacts) < n_impacts:
        sim.advance(0.1, 0.5 if k % 20 < 16 else -0.5)
        k += 1
        if len(sim.impacts) >= done + block:
            now = time.perf_counter()
            size, _ = tracemalloc.get_traced_memory()
            n = len(sim.impacts)
            rows.append({"impacts": n, "t_sim_s": sim.t,
                         "us_per_impact": (now - mark) / (n - done) * 1e6,
                         "traced_mb": size / 2**20, "bytes_per_impact": size / n})
            mark, done = now, n
    tracemalloc.stop()
    return {"impacts": len(sim.impacts), "blocks": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="200,000 steps, 2x10^4 impacts")
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--impacts", type=int, default=None)
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "soak.json"))
    args = parser.parse_args(argv)
    steps = args.steps or (200_000 if args.quick else 2_000_000)
    impacts = args.impacts or (20_000 if args.quick else 100_000)

    core = soak_core(impacts, block=max(1, impacts // 10))
    print(f"core, A = 2 m2 quadratic-drag scene, reversing flow, until {impacts} impacts")
    print(f"{'impacts':>8} {'sim time s':>10} {'us/impact':>10} {'traced MB':>10} {'B/impact':>9}")
    for r in core["blocks"]:
        print(f"{r['impacts']:8d} {r['t_sim_s']:10.1f} {r['us_per_impact']:10.1f} "
              f"{r['traced_mb']:10.2f} {r['bytes_per_impact']:9.0f}")

    fmu = soak_fmu(steps)
    print(f"\nIceImpact.fmu, one instance, {steps} steps of 1 ms (FMPy FMU2Slave)")
    print(f"{'steps':>9} {'RSS MB':>8} {'us/step':>8} {'impacts':>8}")
    for r in fmu["checkpoints"]:
        print(f"{r['steps']:9d} {r['rss_mb']:8.1f} {r['us_per_step']:8.1f} {r['impacts']:8d}")
    print(f"RSS growth after warm-up: {fmu['rss_growth_mb']:+.1f} MB")

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": platform.platform(), "python": sys.version.split()[0],
                               "core": core, "fmu": fmu}, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
