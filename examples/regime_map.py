"""Regime map: flow speed against ice mass (quadratic drag), built with the sweep API.

The Figure 2 scene with quadratic drag (the article's Section 4.2), flow speed ``u`` from 0.01 to
2 m/s (log spacing) against the ice mass ``M`` (log spacing, M/m from 1/8 to 4; ``--axis`` picks
the ice area A or the restitution e instead). Each cell is one run of ``t_end`` seconds summarised
after a transient (:func:`iceimpact.studies.analysis.summarize`):

- left: the dominant vibration frequency over the natural one, ``2 pi f_dom / omega_n``;
- right: the peak displacement ``max |x|`` (log colour scale);
- both: cells in lock-in, ``omega_n T / (2 pi)`` within 5 % of an integer N (T the mean time
  between impacts; N < 10 only: for N >= 10 every ratio is within 5 % of an integer), outlined
  and annotated with N; cells in sticking contact for most of the window are marked with a dot.

    python examples/regime_map.py                  # 20 x 10 runs of 60 s, a few minutes on 2 cores
    python examples/regime_map.py --fine           # 50 x 25 runs of 200 s
    python examples/regime_map.py --axis impact.e  # u against the restitution

Writes ``out/regime_map.csv`` (the sweep table, resumable: rerun to finish an interrupted map)
and ``out/regime_map.png``, and prints a short account of the regimes found.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

from iceimpact import Scene  # noqa: E402
from iceimpact.scene import QUADRATIC_DRAG  # noqa: E402
from iceimpact.studies.analysis import LOCK_IN_TOLERANCE  # noqa: E402
from iceimpact.sweep import sweep  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

#: Second axis choices: (label, values for the default grid, values for --fine, log scale).
AXES = {
    "ice.M": ("ice mass M (kg)", np.geomspace(200.0, 6400.0, 10),
              np.geomspace(200.0, 6400.0, 25), True),
    "ice.A": ("ice drag area A (m$^2$)", np.geomspace(0.25, 8.0, 10),
              np.geomspace(0.25, 8.0, 25), True),
    "impact.e": ("restitution e", np.linspace(0.0, 1.0, 11), np.linspace(0.0, 1.0, 26), False),
}
N_MAX = 9  # lock-in orders marked; for N >= 10 the 5 % tolerance covers every ratio
STICKING = 0.5  # sticking_fraction above which a cell is marked as sticking
REGULAR_CV = 0.1  # cv of the impact intervals at or below which a train counts as regular
MIN_IMPACTS = 4  # impacts in the window (3 intervals) for a mean period T worth marking


def lock_in_cells(data: dict[str, np.ndarray]) -> np.ndarray:
    """Cells marked as lock-in: within the tolerance of N <= N_MAX, enough impacts for T."""
    return ((data["locked"] == 1.0) & (data["nearest_n"] <= N_MAX)
            & (data["n_impacts"] >= MIN_IMPACTS))


def edges(values: np.ndarray, log: bool) -> np.ndarray:
    """Cell edges around grid values: midpoints (geometric on a log axis)."""
    v = np.log(values) if log else np.asarray(values, dtype=float)
    mid = 0.5 * (v[1:] + v[:-1])
    e = np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])
    return np.exp(e) if log else e


def table(rows: list[dict], axis: str, u: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """Columns of the sweep rows as 2-D arrays indexed [y, u]."""
    out = {}
    for key in ("dominant_over_natural", "x_peak_m", "locked", "nearest_n", "omega_ratio",
                "sticking_fraction", "impact_frequency_hz", "n_impacts", "cv_interval"):
        grid = np.full((y.size, u.size), np.nan)
        for row in rows:
            i = int(np.argmin(np.abs(y - row[axis])))
            j = int(np.argmin(np.abs(u - row["flow.u"])))
            grid[i, j] = row[key] if row["status"] == "ok" else np.nan
        out[key] = grid
    return out


def plot(data: dict[str, np.ndarray], u: np.ndarray, y: np.ndarray, axis: str, title: str,
         path: Path) -> None:
    label, _, _, ylog = AXES[axis]
    ue, ye = edges(u, True), edges(y, ylog)
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2), sharey=True, constrained_layout=True)
    panels = [
        ("dominant_over_natural", r"$2\pi f_{dom} / \omega_n$",
         {"cmap": "viridis", "vmin": 0.0, "vmax": 1.2}),
        ("x_peak_m", r"peak displacement $\max|x|$ (m)",
         {"cmap": "magma", "norm": LogNorm(vmin=np.nanmax([np.nanmin(data["x_peak_m"]), 1e-9]),
                                            vmax=np.nanmax(data["x_peak_m"]))}),
    ]
    locked = lock_in_cells(data)
    sticking = data["sticking_fraction"] > STICKING
    for ax, (key, clabel, style) in zip(axes, panels, strict=True):
        mesh = ax.pcolormesh(ue, ye, data[key], shading="flat", **style)
        fig.colorbar(mesh, ax=ax, label=clabel, extend="max" if "vmax" in style else "neither")
        for i, j in zip(*np.nonzero(locked), strict=True):
            regular = data["cv_interval"][i, j] <= REGULAR_CV
            ax.add_patch(plt.Rectangle((ue[j], ye[i]), ue[j + 1] - ue[j], ye[i + 1] - ye[i],
                                       fill=False, edgecolor="white", linewidth=1.2,
                                       linestyle="-" if regular else "--"))
            ax.text(math.sqrt(ue[j] * ue[j + 1]),
                    math.sqrt(ye[i] * ye[i + 1]) if ylog else 0.5 * (ye[i] + ye[i + 1]),
                    f"{int(data['nearest_n'][i, j])}", ha="center", va="center",
                    color="white", fontsize=7, fontweight="bold")
        si, sj = np.nonzero(sticking)
        ax.scatter(np.sqrt(ue[sj] * ue[sj + 1]),
                   np.sqrt(ye[si] * ye[si + 1]) if ylog else 0.5 * (ye[si] + ye[si + 1]),
                   s=4, color="red", label=f"sticking > {STICKING:.0%} of the window")
        ax.set_xscale("log")
        if ylog:
            ax.set_yscale("log")
        ax.set_xlabel("flow speed u (m/s)")
        ax.set_title(clabel)
    axes[0].set_ylabel(label)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower left", fontsize=8,
               frameon=False)
    fig.suptitle(title + f"\noutlined: lock-in, $\\omega_n T/2\\pi$ within "
                 f"{LOCK_IN_TOLERANCE:.0%} of an integer N (annotated; N <= {N_MAX}, "
                 f">= {MIN_IMPACTS} impacts); solid: regular train (cv of the intervals <= "
                 f"{REGULAR_CV:g}), dashed: irregular", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def describe(data: dict[str, np.ndarray], u: np.ndarray, y: np.ndarray, axis: str) -> None:
    """Print what the map shows, with numbers."""
    n_cells = data["x_peak_m"].size
    ok = np.isfinite(data["x_peak_m"])
    sticking = data["sticking_fraction"] > STICKING
    locked = lock_in_cells(data)
    ratio = data["dominant_over_natural"]
    print(f"{n_cells} cells, {int(ok.sum())} ok")
    print(f"sticking for most of the window: {int(sticking.sum())} cells; their dominant "
          f"frequency ratio {np.nanmin(ratio[sticking]) if sticking.any() else math.nan:.3f}.."
          f"{np.nanmax(ratio[sticking]) if sticking.any() else math.nan:.3f}")
    near = np.abs(ratio - 1.0) <= 0.05
    print(f"vibrating within 5 % of omega_n: {int(near.sum())} cells")
    orders = sorted({int(n) for n in data["nearest_n"][locked]})
    regular = locked & (data["cv_interval"] <= REGULAR_CV)
    eligible = ((data["n_impacts"] >= MIN_IMPACTS) & np.isfinite(data["omega_ratio"])
                & (data["nearest_n"] <= N_MAX))
    cv = data["cv_interval"][locked]
    print(f"lock-in (N <= {N_MAX}, >= {MIN_IMPACTS} impacts): {int(locked.sum())} of "
          f"{int(eligible.sum())} eligible cells, orders {orders}; {int(regular.sum())} of them "
          f"with a regular train (cv of the intervals <= {REGULAR_CV:g}; their cv "
          f"{np.min(cv) if cv.size else math.nan:.2f}..{np.max(cv) if cv.size else math.nan:.2f}"
          f", median cv of all eligible cells {np.median(data['cv_interval'][eligible]):.2f})")
    for n in orders:
        cells = np.argwhere(locked & (data["nearest_n"] == n))
        us = sorted({float(u[j]) for _, j in cells})
        ys = sorted({float(y[i]) for i, _ in cells})
        print(f"  N = {n}: {len(cells)} cells, u {us[0]:.3g}..{us[-1]:.3g} m/s, "
              f"{axis} {ys[0]:.3g}..{ys[-1]:.3g}")
    i, j = np.unravel_index(np.nanargmax(data["x_peak_m"]), data["x_peak_m"].shape)
    print(f"largest peak displacement {data['x_peak_m'][i, j]:.3g} m at u = {u[j]:.3g} m/s, "
          f"{axis} = {y[i]:.3g}")
    no_sticking = ok & ~sticking
    if no_sticking.any():
        k = np.nanargmax(np.where(no_sticking, data["x_peak_m"], np.nan))
        i, j = np.unravel_index(k, data["x_peak_m"].shape)
        print(f"largest peak without sticking {data['x_peak_m'][i, j]:.3g} m at u = "
              f"{u[j]:.3g} m/s, {axis} = {y[i]:.3g} (2 pi f_dom / omega_n = {ratio[i, j]:.3f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--axis", choices=sorted(AXES), default="ice.M",
                        help="second parameter (default ice.M)")
    parser.add_argument("--fine", action="store_true", help="50 x 25 runs of 200 s")
    parser.add_argument("--t-end", type=float, default=None, help="s (default 60, fine 200)")
    parser.add_argument("--transient", type=float, default=None,
                        help="s (default t_end / 3)")
    parser.add_argument("--workers", type=int, default=None, help="default: all cores")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "out")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace a regime_map.csv from different settings")
    args = parser.parse_args()

    label, coarse, fine, _ = AXES[args.axis]
    u = np.geomspace(0.01, 2.0, 50 if args.fine else 20)
    y = fine if args.fine else coarse
    t_end = args.t_end or (200.0 if args.fine else 60.0)
    transient = t_end / 3.0 if args.transient is None else args.transient
    base = Scene(drag_model=QUADRATIC_DRAG)
    csv_path = args.out_dir / "regime_map.csv"
    rows = sweep(base, {args.axis: y.tolist(), "flow.u": u.tolist()}, t_end=t_end,
                 transient=transient, out=csv_path, workers=args.workers,
                 overwrite=args.overwrite)
    data = table(rows, args.axis, u, y)
    title = (f"Figure 2 scene, quadratic drag, {len(rows)} runs of {t_end:g} s "
             f"(measures over t >= {transient:.3g} s)")
    png = args.out_dir / "regime_map.png"
    plot(data, u, y, args.axis, title, png)
    describe(data, u, y, args.axis)
    print(f"total run time {sum(r['wall_s'] for r in rows):.0f} s; -> {csv_path}, {png}")


if __name__ == "__main__":
    main()
