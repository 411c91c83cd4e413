"""Design map: damage-equivalent load and extreme of the base shear over flow speed and ice mass.

The Figure 2 scene with quadratic drag (the article's Section 4.2), flow speed ``u`` (log spacing)
against the ice mass ``M`` (log spacing), built with the sweep API. Each cell is one run of
``t_end`` seconds whose design loads (:mod:`iceimpact.studies.loads`, columns of
:func:`iceimpact.studies.analysis.summarize`) are taken after a transient:

- left: the 1 Hz damage-equivalent load of the spring force ``k x`` (the base shear of the SDOF
  structure), Wöhler exponent ``m`` (default 4; ``del_m<m>_1Hz_N``), annotated in kN;
- right: the extreme base shear ``max |k x|`` (from ``kx_max_N`` and ``kx_min_N``).

Cells in sticking contact for most of the window are marked with a dot. See
docs/explanation/design-loads.md for what the numbers are and their limits (one SDOF structure, one
load case per cell, no safety factors).

    python examples/design_map.py              # 8 x 6 runs of 60 s, a few minutes on 2 cores
    python examples/design_map.py --m 10       # DEL for a Wöhler exponent of 10
    python examples/design_map.py --quick      # 2 x 2 runs of 6 s (a smoke test)

Writes ``docs/img/design_map.csv`` (the whole sweep table, one row per cell) and
``docs/img/design_map.png`` (``--out-dir`` to change the folder), and prints the extreme cells.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from doc_blocks import begin, fenced, read_block, unfenced, write_block  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

from iceimpact import Scene  # noqa: E402
from iceimpact.scene import QUADRATIC_DRAG  # noqa: E402
from iceimpact.studies.loads import WOHLER_EXPONENTS  # noqa: E402
from iceimpact.sweep import sweep  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
STICKING = 0.5  # sticking_fraction above which a cell is marked as sticking


def edges(values: np.ndarray) -> np.ndarray:
    """Cell edges around log-spaced grid values (geometric midpoints)."""
    v = np.log(values)
    mid = 0.5 * (v[1:] + v[:-1])
    if v.size == 1:
        return np.exp(np.array([v[0] - 0.5, v[0] + 0.5]))
    return np.exp(np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]]))


def grid_of(rows: list[dict], key: str, u: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Column ``key`` of the sweep rows as a 2-D array indexed [mass, u] (nan for errors)."""
    out = np.full((mass.size, u.size), np.nan)
    for row in rows:
        i = int(np.argmin(np.abs(mass - row["ice.M"])))
        j = int(np.argmin(np.abs(u - row["flow.u"])))
        out[i, j] = row[key] if row["status"] == "ok" else np.nan
    return out


def write_csv(rows: list[dict], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v)
                             for k, v in row.items()})


def plot(rows: list[dict], u: np.ndarray, mass: np.ndarray, m: int, title: str,
         path: Path) -> None:
    dels = grid_of(rows, f"del_m{m}_1Hz_N", u, mass)
    peak = np.fmax(np.abs(grid_of(rows, "kx_max_N", u, mass)),
                   np.abs(grid_of(rows, "kx_min_N", u, mass)))
    sticking = grid_of(rows, "sticking_fraction", u, mass) > STICKING
    ue, me = edges(u), edges(mass)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True, constrained_layout=True)
    panels = [(dels, f"1 Hz DEL of the base shear k x, m = {m} (N)"),
              (peak, "extreme base shear max |k x| (N)")]
    for ax, (data, label) in zip(axes, panels, strict=True):
        positive = data[np.isfinite(data) & (data > 0.0)]
        norm = LogNorm(vmin=positive.min(), vmax=positive.max()) if positive.size else None
        mesh = ax.pcolormesh(ue, me, np.where(data > 0.0, data, np.nan), shading="flat",
                             cmap="magma", norm=norm)
        fig.colorbar(mesh, ax=ax, label="N")
        for i in range(mass.size):
            for j in range(u.size):
                if math.isfinite(data[i, j]):
                    ax.text(math.sqrt(ue[j] * ue[j + 1]), math.sqrt(me[i] * me[i + 1]),
                            f"{data[i, j] / 1e3:.2g}", ha="center", va="center", fontsize=7,
                            color="white" if norm is None or norm(data[i, j]) < 0.6
                            else "black")
        si, sj = np.nonzero(sticking)
        ax.scatter(np.sqrt(ue[sj] * ue[sj + 1]), np.sqrt(me[si] * me[si + 1]) * 1.25, s=6,
                   color="cyan", label=f"sticking > {STICKING:.0%} of the window")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("flow speed u (m/s)")
        ax.set_title(label + ", cells in kN", fontsize=10)
    axes[0].set_ylabel("ice mass M (kg)")
    if sticking.any():
        fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower left", fontsize=8,
                   frameon=False)
    fig.suptitle(title, fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def describe(rows: list[dict], m: int) -> list[str]:
    """The cells with the largest DEL and extreme, and the errors: one line each (also
    printed)."""
    ok = [r for r in rows if r["status"] == "ok"]
    lines = [f"{len(rows)} cells, {len(ok)} ok"]
    for r in rows:
        if r["status"] != "ok":
            lines.append(f"  u = {r['flow.u']:.3g} m/s, M = {r['ice.M']:.4g} kg: {r['status']}")
    if ok:
        key = f"del_m{m}_1Hz_N"
        for top in sorted(ok, key=lambda r: r[key], reverse=True)[:3]:
            lines.append(f"large 1 Hz DEL (m = {m}): {top[key]:.4g} N at u = "
                         f"{top['flow.u']:.3g} m/s, M = {top['ice.M']:.4g} kg "
                         f"({top['n_impacts']:.0f} impacts in the window)")
        top = max(ok, key=lambda r: max(abs(r["kx_max_N"]), abs(r["kx_min_N"])))
        lines.append(f"largest base shear: max k x = {top['kx_max_N']:.4g} N at t = "
                     f"{top['kx_max_t_s']:.4g} s, min k x = {top['kx_min_N']:.4g} N, at u = "
                     f"{top['flow.u']:.3g} m/s, M = {top['ice.M']:.4g} kg")
        stuck = [r for r in ok if r["sticking_fraction"] > STICKING]
        if stuck:
            lines.append(f"sticking for most of the window: {len(stuck)} cells, 1 Hz DEL "
                         f"(m = {m}) {min(r[key] for r in stuck):.3g}.."
                         f"{max(r[key] for r in stuck):.3g} N, max k x "
                         f"{min(r['kx_max_N'] for r in stuck):.4g}.."
                         f"{max(r['kx_max_N'] for r in stuck):.4g} N")
    for line in lines:
        print(line)
    return lines


BEGIN = begin("design_map.py")


def write_doc(path: Path, lines: list[str]) -> bool:
    """Replace this script's account in ``path`` (a fenced text block); True if it changed."""
    return write_block(path, BEGIN, fenced(lines))


def generated_lines(path: Path) -> list[str]:
    """The lines of this script's account currently in ``path``."""
    return unfenced(read_block(path, BEGIN))






def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--m", type=int, choices=WOHLER_EXPONENTS, default=4,
                        help="Woehler exponent of the plotted DEL (default 4)")
    parser.add_argument("--quick", action="store_true", help="2 x 2 runs of 6 s")
    parser.add_argument("--t-end", type=float, default=None, help="s (default 60, quick 6)")
    parser.add_argument("--transient", type=float, default=None,
                        help="s (default t_end / 3)")
    parser.add_argument("--workers", type=int, default=None, help="default: all cores")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "docs" / "img")
    parser.add_argument("--write-doc", type=Path, metavar="MD",
                        help="rewrite the generated account of MD "
                             "(docs/explanation/design-loads.md; the default map only)")
    args = parser.parse_args(argv)

    if args.quick:
        u, mass = np.array([0.1, 1.0]), np.array([800.0, 3200.0])
    else:
        u, mass = np.geomspace(0.02, 2.0, 8), np.geomspace(200.0, 6400.0, 6)
    t_end = args.t_end or (6.0 if args.quick else 60.0)
    transient = t_end / 3.0 if args.transient is None else args.transient
    base = Scene(drag_model=QUADRATIC_DRAG)
    rows = sweep(base, {"ice.M": mass.tolist(), "flow.u": u.tolist()}, t_end=t_end,
                 transient=transient, workers=args.workers, progress=not args.quick)
    csv_path = args.out_dir / "design_map.csv"
    write_csv(rows, csv_path)
    title = (f"Figure 2 structure, quadratic drag, {len(rows)} runs of {t_end:g} s, loads over "
             f"t >= {transient:.3g} s")
    png = args.out_dir / "design_map.png"
    plot(rows, u, mass, args.m, title, png)
    lines = describe(rows, args.m)
    print(f"total run time {sum(r['wall_s'] for r in rows):.0f} s; -> {csv_path}, {png}")
    if args.write_doc is not None:
        if args.quick or args.t_end or args.transient is not None or args.m != 4:
            print("--write-doc writes the account of the default map only: not written")
            return 2
        changed = write_doc(args.write_doc, lines)
        print(f"{args.write_doc}: {'rewritten' if changed else 'unchanged'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
