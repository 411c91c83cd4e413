"""FMU state through FMI: fmi2GetFMUstate / fmi2SerializeFMUstate cost and size vs run length.

    python benchmarks/fmu_state_fmi.py [--quick] [--repeat N]

Builds IceImpact.fmu into a temporary folder, steps it with FMPy's FMU2Slave (1 ms steps) on an
elastic scene that keeps impacting (the Figure 2 scene with k = 1e8 N/m: 1e5 impacts in ~370 s),
and at 10, 1e3, 1e4 and 1e5 impacts (``--quick``: up to 1e3) times, as a host sees them,

- ``fmi2GetFMUstate`` (the goal: <= 1 ms at any run length),
- ``fmi2SerializeFMUstate`` and the size of the blob (the goal: <= 16 kB),
- ``fmi2DeSerializeFMUstate`` + ``fmi2SetFMUstate`` of that blob,

medians over ``--repeat`` calls. ``benchmarks/fmu_state.py`` has the core-level figures beside
the deep copy this replaced. Prints a table, writes ``benchmarks/results/fmu_state_fmi.json``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import tempfile
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent

from fmu_state import _median_time  # noqa: E402  (the core-level benchmark's timer)

DT = 1e-3
VALUES = {"structure.k": 1e8}


def _build(dest: Path) -> Path:
    spec = importlib.util.spec_from_file_location("build_fmu", ROOT / "build_fmu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build(dest)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="up to 1e3 impacts")
    parser.add_argument("--repeat", type=int, default=200, help="calls per timing (median)")
    args = parser.parse_args()
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    targets = [10, 1_000] if args.quick else [10, 1_000, 10_000, 100_000]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fmu = _build(Path(tmp))
        md = read_model_description(str(fmu))
        unzipped = extract(str(fmu), unzipdir=str(Path(tmp) / "x"))
        refs = {v.name: v.valueReference for v in md.modelVariables}
        slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName="s")
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.setReal([refs[k] for k in VALUES], list(VALUES.values()))
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        k, count = 0, 0
        for target in targets:
            while count < target:
                slave.doStep(currentCommunicationPoint=k * DT,
                             communicationStepSize=(k + 1) * DT - k * DT)
                k += 1
                count = slave.getInteger([refs["contact.count"]])[0]
            states = []

            def get(states=states):
                state = slave.getFMUstate()
                states.append(state)
                return state

            t_get, state = _median_time(get, args.repeat)
            t_ser, blob = _median_time(lambda state=state: slave.serializeFMUstate(state),
                                       args.repeat)

            def restore(blob=blob):
                restored = slave.deSerializeFMUstate(blob)
                slave.setFMUstate(restored)
                slave.freeFMUstate(restored)

            t_set, _ = _median_time(restore, args.repeat)
            for s in states:
                slave.freeFMUstate(s)
            rows.append({"impacts": count, "t_s": k * DT, "get_ms": 1e3 * t_get,
                         "serialize_ms": 1e3 * t_ser, "bytes": len(blob),
                         "deserialize_set_ms": 1e3 * t_set})
        slave.terminate()
        slave.freeInstance()

    print(f"{'impacts':>8} {'t (s)':>8} | {'get ms':>7} {'serialize ms':>12} {'bytes':>6} "
          f"{'deserialize+set ms':>18}")
    for r in rows:
        print(f"{r['impacts']:>8} {r['t_s']:>8.1f} | {r['get_ms']:>7.3f} {r['serialize_ms']:>12.3f}"
              f" {r['bytes']:>6} {r['deserialize_set_ms']:>18.3f}")
    out = HERE / "results" / "fmu_state_fmi.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({
        "benchmark": "fmu_state_fmi", "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "machine": platform.platform(), "python": platform.python_version(),
        "scene": VALUES, "step_s": DT, "repeat": args.repeat, "rows": rows}, indent=2) + "\n")
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
