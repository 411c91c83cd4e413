"""Size of the standalone IceImpact.fmu and its time to the first fmi2Instantiate, beside the
default FMU.

    python benchmarks/standalone_start.py [--rounds N]

Builds both FMUs (``build_fmu.build`` and ``build_fmu.make_standalone``), then measures:

- the size of each .fmu and of its extracted folder, and the time to extract it (what a host
  does first, each run for some hosts);
- the time from a native host's start to the return of its first fmi2Instantiate (the C host of
  tests/c_host with ``-T``, an empty environment): the default FMU, which loads the machine's
  libpython, numpy and scipy; the standalone FMU on the same machine; and the standalone FMU in a
  mount namespace with no Python (root only; skipped otherwise).

Rounds are interleaved (the machine is noisy) and the table gives the median and the best.
Prints a table and writes ``benchmarks/results/standalone_start.json``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from datetime import UTC, datetime
from pathlib import Path

from tree import ROOT, load

build_fmu = load("build_fmu.py")
native_host = load("tests/native_host.py")
C_HOST, compile_c, run_empty_env = (native_host.C_HOST, native_host.compile_c,
                                    native_host.run_empty_env)

OUT = ROOT / "benchmarks" / "results" / "standalone_start.json"


def folder_size(folder: Path) -> tuple[int, int]:
    files = [p for p in folder.rglob("*") if p.is_file()]
    return sum(p.stat().st_size for p in files), len(files)


def namespace_command(command: list[str]) -> list[str] | None:
    """``command`` with every Python of the machine hidden, or None where that cannot be done."""
    import pytest

    without_python = native_host.without_python

    try:
        return without_python(command)
    except pytest.skip.Exception:
        return None


def instantiate_seconds(command: list[str]) -> float:
    done = subprocess.run(command, env={}, capture_output=True, text=True, timeout=300)
    if done.returncode != 0:
        raise RuntimeError(f"{command[-3:]} failed:\n{done.stderr[-2000:]}")
    return float(done.stdout.split()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7, help="interleaved rounds (default 7)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="standalone_bench_") as tmp:
        tmp = Path(tmp)
        default = build_fmu.build(tmp / "dist")
        standalone = build_fmu.make_standalone(default, tmp / "dist" / "standalone")
        host = compile_c(C_HOST / "host.c", tmp / "host", "-ldl")
        fmus = {"default": default, "standalone": standalone}
        sizes, extract_times, dirs = {}, {name: [] for name in fmus}, {}
        for round_ in range(args.rounds):
            for name, fmu in fmus.items():
                target = tmp / f"{name}_{round_}"
                start = time.perf_counter()
                with zipfile.ZipFile(fmu) as archive:
                    archive.extractall(target)
                extract_times[name].append(time.perf_counter() - start)
                dirs[name] = target
        for name, fmu in fmus.items():
            unpacked, files = folder_size(dirs[name])
            sizes[name] = {"fmu_bytes": fmu.stat().st_size, "extracted_bytes": unpacked,
                           "files": files}
        cases = {
            "default FMU, machine's Python": [str(host), str(dirs["default"]), "-T"],
            "standalone FMU, machine with Python": [str(host), str(dirs["standalone"]), "-T"],
        }
        hidden = namespace_command([str(host), str(dirs["standalone"]), "-T"])
        if hidden:
            cases["standalone FMU, no Python on the machine"] = hidden
        # a first run of each warms the page cache: what the rounds measure is a warm start
        for command in cases.values():
            instantiate_seconds(command) if command[0] != "unshare" else subprocess.run(
                command, capture_output=True, timeout=300)
        times = {name: [] for name in cases}
        for _ in range(args.rounds):
            for name, command in cases.items():
                if command[0] == "unshare":
                    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
                    times[name].append(float(done.stdout.split()[-1]))
                else:
                    times[name].append(instantiate_seconds(command))
        assert run_empty_env([str(host), str(dirs["standalone"]), "-n", "1"]).returncode == 0

    print(f"{'FMU':<12}{'.fmu MB':>10}{'extracted MB':>14}{'files':>8}{'extract s (median)':>20}")
    for name in fmus:
        s = sizes[name]
        print(f"{name:<12}{s['fmu_bytes'] / 1e6:>10.1f}{s['extracted_bytes'] / 1e6:>14.1f}"
              f"{s['files']:>8}{statistics.median(extract_times[name]):>20.3f}")
    print()
    print(f"{'to the first fmi2Instantiate (C host, env -i)':<48}{'median s':>10}{'best s':>10}")
    for name, values in times.items():
        print(f"{name:<48}{statistics.median(values):>10.3f}{min(values):>10.3f}")
    result = {
        "benchmark": "standalone_start",
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "machine": {"python": platform.python_version(), "platform": platform.platform()},
        "rounds": args.rounds,
        "sizes": sizes,
        "extract_seconds": extract_times,
        "instantiate_seconds": times,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(result, indent=2) + "\n")
    print(f"\nwrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
