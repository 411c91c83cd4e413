"""The events of the reference runs (tests/reference_digests.py) in a base commit and in this
tree, impact by impact: for a change of arithmetic that moves bits, how far each run's events
moved.

    python tools/compare_reference_events.py [--base COMMIT] [--cases NAME ...] [--out FILE.md]

For each case: the impact counts before and after, the largest shift of an impact time and of an
impulse (relative to the largest impulse of the run) over the impacts both runs have, the first
impact whose time moved by more than 1e-9 s, the communication steps whose sticking flag
differs, and how far each sticking start moved (stepped runs: the simulator's sticking_since).
Both sides run in fresh processes, each with its own tree's package first on PYTHONPATH (and this
tree's tests/, for the reference runs' definitions).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_WORKER = r"""
import json, sys
import reference_digests as rd
from iceimpact import Scene, run

def events(name, kind, changes, t_end, h, flow):
    scene = Scene(**changes)
    if kind == "run":
        result = run(scene, t_end, dt=h)
        return {"t": result.impacts["t"].tolist(), "impulse": result.impacts["impulse"].tolist(),
                "sticking": [bool(s) for s in result.sticking]}
    sim, reports = stepped(scene, kind, t_end, h, flow)
    return {"t": [i.t for i in sim.impacts], "impulse": [i.impulse for i in sim.impacts],
            "sticking": [bool(r.sticking) for r in reports], "starts": list(STARTS)}

STARTS = []

def stepped(scene, kind, t_end, h, flow):
    # rd.stepped, noting each sticking start (the simulator's sticking_since) on the way
    STARTS.clear()
    real_advance = rd.Simulator.advance

    def advance(sim, *args):
        report = real_advance(sim, *args)
        since = sim.sticking_since
        if since is not None and (not STARTS or STARTS[-1] != since):
            STARTS.append(since)
        return report
    rd.Simulator.advance = advance
    try:
        return rd.stepped(scene, kind, t_end, h, flow)
    finally:
        rd.Simulator.advance = real_advance

names = json.loads(sys.argv[1])
print(json.dumps({c[0]: events(*c) for c in rd.CASES if not names or c[0] in names}))
"""


def _extract(commit: str, dest: Path) -> Path:
    """The base commit's package folder (fmu_src) under dest."""
    archive = subprocess.run(["git", "archive", commit, "fmu_src"], cwd=ROOT,
                             capture_output=True, check=True).stdout
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(dest, filter="data")
    return dest / "fmu_src"


def _events(package: Path, names: list[str]) -> dict:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(package), str(ROOT / "tests")])}
    done = subprocess.run([sys.executable, "-c", _WORKER, json.dumps(names)],
                          env=env, capture_output=True, text=True, check=True, cwd=ROOT)
    return json.loads(done.stdout)


def compare(before: dict, after: dict) -> dict:
    """The shifts of one case's events (see the module's docstring)."""
    n = min(len(before["t"]), len(after["t"]))
    shifts = [abs(a - b) for a, b in zip(before["t"][:n], after["t"][:n], strict=True)]
    scale = max([abs(p) for p in before["impulse"] + after["impulse"]] or [0.0]) or 1.0
    impulse = max([abs(a - b) / scale for a, b in zip(before["impulse"][:n],
                                                       after["impulse"][:n], strict=True)]
                  or [0.0])
    moved = next((k for k, s in enumerate(shifts) if s > 1e-9), None)
    flags = sum(a != b for a, b in zip(before["sticking"], after["sticking"], strict=True))
    starts_before, starts_after = before.get("starts", []), after.get("starts", [])
    starts = [b - a for a, b in zip(starts_before, starts_after, strict=False)]
    return {"impacts_before": len(before["t"]), "impacts_after": len(after["t"]),
            "max_time_shift_s": max(shifts or [0.0]), "max_impulse_shift": impulse,
            "first_moved_impact": moved, "sticking_flags_differ": flags,
            "sticking_starts": (len(starts_before), len(starts_after), starts),
            "identical": before == after}


def _starts(starts: tuple[int, int, list[float]]) -> str:
    before, after, shifts = starts
    listed = ", ".join(f"{s:+.2e} s" for s in shifts[:4]) + (" ..." if len(shifts) > 4 else "")
    return f"{before} / {after}" + (f": {listed}" if shifts and any(shifts) else "")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="HEAD", help="the commit before (default HEAD)")
    parser.add_argument("--cases", nargs="*", default=[], help="case names (default: all)")
    parser.add_argument("--out", type=Path, help="also write the table (Markdown) here")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="events_") as tmp:
        before = _events(_extract(args.base, Path(tmp)), args.cases)
    after = _events(ROOT / "fmu_src", args.cases)
    lines = [f"Before: {args.base}; after: this tree. Impact times and impulses of the reference "
             "runs (tests/reference_digests.py).", "",
             "| case | impacts before / after | identical | largest time shift | largest impulse "
             "shift (of the largest impulse) | first impact moved > 1e-9 s | sticking flags "
             "differing | sticking starts before / after: shifts (stepped runs) |",
             "|---|---:|---|---:|---:|---:|---:|---|"]
    for name, events in after.items():
        row = compare(before[name], events)
        first = "-" if row["first_moved_impact"] is None else f"#{row['first_moved_impact'] + 1}"
        lines.append(f"| {name} | {row['impacts_before']} / {row['impacts_after']} | "
                     f"{'yes' if row['identical'] else 'no'} | {row['max_time_shift_s']:.1e} s | "
                     f"{row['max_impulse_shift']:.1e} | {first} | "
                     f"{row['sticking_flags_differ']} | {_starts(row['sticking_starts'])} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
