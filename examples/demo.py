"""Simulate IceImpact.fmu on the article's Figure 2 scene through FMPy.

    python build_fmu.py && python examples/demo.py [--fmu dist/IceImpact.fmu] [--stop-time 400]
        [--csv-interval 0.01 | --full-rate] [--out out]

400 s at a communication step of 1 ms (400,000 doStep calls, with a progress bar). Writes
``out/demo.png`` (displacements, impulses, impacts marked, from every step), prints a short
summary and writes ``out/demo.csv``: every output every 10 ms (``--csv-interval``; 40,001 rows,
about 7 MB for 400 s), or at every 1 ms step with ``--full-rate`` (about 67 MB).

Each CSV row is the state at its time. The per-step outputs cover the whole interval since the
previous row: ``contact.impulse`` is the sum of the impulses of the steps in it (so the column
still sums to the total impulse) and ``contact.force`` that sum over the interval's length (the
mean force). ``contact.count`` and ``contact.t_last`` are cumulative: the row holds their value
at its time.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
STEP = 1e-3  # communication step, s
CSV_INTERVAL = 1e-2  # default interval between the rows of the CSV, s
#: Outputs delivered per communication step: summed over a CSV interval (``contact.force`` is
#: recomputed as the summed impulse over the interval's length).
SUMMED = ("contact.impulse",)


def simulate(fmu: Path, stop_time: float, start_values: dict | None = None) -> np.ndarray:
    """Run the FMU with FMPy, showing a progress bar; the structured result array."""
    n_steps = round(stop_time / STEP)
    with tqdm(total=n_steps, unit="step", unit_scale=True, desc="IceImpact.fmu",
              mininterval=0.5) as bar:
        done = 0

        def step_finished(time: float, recorder) -> bool:
            nonlocal done
            done += 1
            if done % 1000 == 0 or done == n_steps:
                bar.update(done - bar.n)
            return True  # keep going

        return simulate_fmu(str(fmu), start_time=0.0, stop_time=stop_time,
                            output_interval=STEP,  # the communication step of a CS FMU
                            start_values=start_values or {}, step_finished=step_finished)


def decimate(result: np.ndarray, every: int) -> np.ndarray:
    """Every ``every``-th row of ``result`` (the first and the last always kept), with the
    per-step outputs of the steps in between accumulated (see the module docstring).

    Row 0 is the start (no step before it); row i > 0 covers the steps after the previous kept
    row up to and including its own.
    """
    n = len(result)
    if every <= 1 or n <= 2:
        return result.copy()
    keep = np.arange(0, n, every)
    if keep[-1] != n - 1:
        keep = np.append(keep, n - 1)
    out = result[keep].copy()
    for name in SUMMED:
        if name in result.dtype.names:
            total = np.concatenate(([0.0], np.cumsum(result[name][1:], dtype=float)))
            out[name][1:] = np.diff(total[keep])
    if "contact.force" in result.dtype.names and "contact.impulse" in result.dtype.names:
        span = np.diff(result["time"][keep])
        out["contact.force"][1:] = out["contact.impulse"][1:] / span
    return out


def write_csv(result: np.ndarray, path: Path) -> None:
    """Every column of ``result``; integers and Booleans as integers, reals to 12 digits."""
    names = result.dtype.names
    columns = [result[name].astype(int) if result[name].dtype == bool else result[name]
               for name in names]
    formats = ["%d" if np.issubdtype(c.dtype, np.integer) else "%.12g" for c in columns]
    table = np.rec.fromarrays(columns, names=names)
    np.savetxt(path, table, delimiter=",", header=",".join(names), comments="", fmt=formats)


def summary(result: np.ndarray) -> dict:
    t = result["time"]
    active = result["contact.active"].astype(bool)
    if active.any():
        first = int(np.argmax(active))
        # the start of the sticking phase that lasts to the end, if it does
        last_free = np.flatnonzero(~active)
        lasting = active[-1]
        since = t[last_free[-1] + 1] if lasting and last_free.size else t[first]
        sticking = (f"from t = {since:.3f} s to the end" if lasting
                    else f"first at t = {t[first]:.3f} s (not at the end)")
    else:
        sticking = "never"
    return {
        "impacts": int(result["contact.count"][-1]),
        "peak |x| (m)": float(np.max(np.abs(result["structure.x"]))),
        "peak impulse per step (N.s)": float(np.max(result["contact.impulse"])),
        "sticking": sticking,
    }


def plot(result: np.ndarray, path: Path) -> None:
    """The four panels of :func:`iceimpact.plots.plot_series` (``iceimpact simulate --plot``
    draws the same for a run of the core)."""
    from iceimpact.plots import plot_series

    plot_series(result, path, title="IceImpact.fmu, Figure 2 scene",
                interval=f"{STEP * 1e3:g} ms step")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", type=Path, default=ROOT / "dist" / "IceImpact.fmu")
    parser.add_argument("--stop-time", type=float, default=400.0, help="s (default 400)")
    parser.add_argument("--out", type=Path, default=ROOT / "out", help="output folder")
    rate = parser.add_mutually_exclusive_group()
    rate.add_argument("--csv-interval", type=float, default=CSV_INTERVAL, metavar="S",
                      help=f"time between the rows of out/demo.csv, s: a multiple of the "
                           f"{STEP * 1e3:g} ms step (default {CSV_INTERVAL:g})")
    rate.add_argument("--full-rate", action="store_true",
                      help="write every output at every 1 ms step to out/demo.csv (large)")
    args = parser.parse_args(argv)
    every = 1 if args.full_rate else round(args.csv_interval / STEP)
    if not args.full_rate and (every < 1 or abs(every * STEP - args.csv_interval) > 1e-9):
        parser.error(f"--csv-interval {args.csv_interval:g}: must be a positive multiple of the "
                     f"communication step {STEP:g} s")
    if not args.fmu.exists():
        print(f"{args.fmu} not found: run `python build_fmu.py` first", file=sys.stderr)
        return 1
    args.out.mkdir(parents=True, exist_ok=True)

    result = simulate(args.fmu, args.stop_time)  # the defaults are the Figure 2 scene
    csv_path, png_path = args.out / "demo.csv", args.out / "demo.png"
    table = decimate(result, every)
    write_csv(table, csv_path)
    plot(result, png_path)

    print(f"Figure 2 scene, {args.stop_time:g} s at {STEP * 1e3:g} ms steps:")
    for key, value in summary(result).items():
        print(f"  {key:28s} {value:.6g}" if isinstance(value, float) else f"  {key:28s} {value}")
    size = csv_path.stat().st_size / 1e6
    print(f"wrote {csv_path.relative_to(ROOT) if csv_path.is_relative_to(ROOT) else csv_path}"
          f" ({len(table)} rows, every {every * STEP * 1e3:g} ms, {size:.1f} MB)"
          f" and {png_path.relative_to(ROOT) if png_path.is_relative_to(ROOT) else png_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
