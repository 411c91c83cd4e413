"""Plots from the command line: ``iceimpact simulate --plot`` (the demo's panels for any scene)
and ``iceimpact plot`` (a sweep table as maps over two varied parameters, a load-case result,
a .out time series). Each PNG is opened (its pixel size) and the returned figure's axes are
checked for labels with units; bad options give argparse errors naming what is needed."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")
from PIL import Image  # noqa: E402  (matplotlib needs pillow: it is there with it)

from cli_helpers import usage_error  # noqa: E402
from iceimpact import Scene, run  # noqa: E402
from iceimpact.cli import main  # noqa: E402
from iceimpact.plots import (  # noqa: E402
    DPI,
    PlotError,
    plot_load_cases,
    plot_run,
    plot_table,
    select_rows,
    sweep_axes,
)
from iceimpact.sweep import read_table, sweep  # noqa: E402

UNIT = re.compile(r"\((?:[^()]+)\)$")  # a label ending in its unit, e.g. "x (µm)", "ice.M (kg)"


def png_size(path: Path) -> tuple[int, int]:
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as image:
        return image.size


def expected_size(fig) -> tuple[int, int]:
    width, height = fig.get_size_inches()
    return round(width * DPI), round(height * DPI)


@pytest.fixture(scope="module")
def sweep_csv(tmp_path_factory) -> Path:
    """A 2 x 2 sweep of the Figure 2 scene over ice.M and flow.u (3 s runs)."""
    path = tmp_path_factory.mktemp("sweep") / "map.csv"
    sweep(Scene(), {"ice.M": [800.0, 3200.0], "flow.u": [0.1, 1.0]}, t_end=3.0, transient=1.0,
          dt=0.01, out=path, workers=1, progress=False)
    return path


def test_simulate_plot_draws_the_demo_panels(tmp_path: Path, capsys) -> None:
    png = tmp_path / "run.png"
    assert main(["simulate", "--t-end", "12", "--dt", "0.01", "--set", "ice.M=800",
                 "--plot", str(png)]) == 0
    assert f"plot: {png}" in capsys.readouterr().out
    assert png_size(png) == (1100, 1200)

    fig = plot_run(run(Scene(ice_M=800.0), 12.0, dt=0.01), tmp_path / "again.png", title="t")
    assert png_size(tmp_path / "again.png") == expected_size(fig) == (1100, 1200)
    axes = fig.get_axes()
    assert len(axes) == 5  # four panels and the zoom's twin axis
    for ax in axes:
        assert UNIT.search(ax.get_ylabel()), ax.get_ylabel()
        assert ax.get_xlabel() in ("time (s)", "")  # the twin shares the zoom's time axis
    ylabels = [ax.get_ylabel() for ax in axes]
    assert ylabels[0] == "x (µm)" and ylabels[1] == "z (mm)" and "impulse (N.s)" in ylabels
    # the impacts are marked: one marker per sample interval holding an impact
    markers = axes[0].get_lines()[1]
    assert 0 < len(markers.get_xdata()) <= 12 * 100


def test_plot_sweep_table_as_a_map(sweep_csv: Path, tmp_path: Path, capsys) -> None:
    png = tmp_path / "map.png"
    assert main(["plot", str(sweep_csv), "--out", str(png), "--column", "x_peak_m"]) == 0
    assert f"-> {png}" in capsys.readouterr().out
    fig, path, kind = plot_table(sweep_csv, tmp_path / "two.png",
                                 columns=["del_m4_1Hz_N", "n_impacts"])
    assert kind == "sweep" and png_size(path) == expected_size(fig)
    assert png_size(png)[1] == 460
    panels = [ax for ax in fig.get_axes() if ax.get_title()]
    assert [ax.get_title() for ax in panels] == ["del_m4_1Hz_N", "n_impacts"]
    assert [ax.get_xlabel() for ax in panels] == ["flow.u (m/s)"] * 2
    assert panels[0].get_ylabel() == "ice.M (kg)"
    colorbars = [ax.get_ylabel() for ax in fig.get_axes() if not ax.get_title()]
    assert colorbars == ["del_m4_1Hz_N (N)", "n_impacts (-)"]
    assert panels[0].get_xscale() == "log"  # 0.1 and 1.0: a decade apart
    # every cell is written in it, with the table's value
    rows = read_table(sweep_csv)
    written = {t.get_text() for t in panels[1].texts}
    assert written == {f"{float(r['n_impacts']):.3g}" for r in rows}
    # default: the table's name with .png, the 1 Hz DEL and the peak displacement
    assert main(["plot", str(sweep_csv)]) == 0
    assert sweep_csv.with_suffix(".png").exists()


def test_sweep_map_errors_name_what_is_needed(sweep_csv: Path, tmp_path: Path, capsys) -> None:
    err = usage_error(capsys, ["plot", str(sweep_csv), "--column", "nope"])
    assert "--column 'nope' is not a result column" in err and "del_m4_1Hz_N" in err
    err = usage_error(capsys, ["plot", str(sweep_csv), "--out", "map.jpg"])
    assert "--out 'map.jpg'" in err and ".png, .pdf or .svg" in err
    err = usage_error(capsys, ["plot", str(sweep_csv), "--x", "ice.A"])
    assert "'ice.A' is not a parameter of this sweep" in err and "ice.M, flow.u" in err
    err = usage_error(capsys, ["plot", str(tmp_path / "missing.csv")])
    assert "no such file" in err
    err = usage_error(capsys, ["plot", str(sweep_csv), "--at", "flow.u"])
    assert "--at 'flow.u': expected NAME=VALUE" in err

    # one varied parameter: no map
    rows = read_table(sweep_csv)
    one = tmp_path / "one.csv"
    with open(one, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(r for r in rows if r["ice.M"] == 800.0)
    err = usage_error(capsys, ["plot", str(one)])
    assert "two varied parameters" in err and "varies flow.u" in err


def test_three_varied_parameters_need_axes_and_a_slice(sweep_csv: Path) -> None:
    rows = read_table(sweep_csv)
    three = [{**{k: v for k, v in r.items() if k != "status"}, "impact.e": e,
              "status": r["status"]} for r in rows for e in (0.5, 1.0)]
    three = [{k: r[k] for k in ["run", "ice.M", "flow.u", "impact.e", "status",
                                *list(rows[0])[4:]]} for r in three]
    with pytest.raises(PlotError, match="--x NAME and --y NAME"):
        sweep_axes(three)
    with pytest.raises(PlotError, match="--at NAME=VALUE.*impact.e"):
        sweep_axes(three, x="flow.u", y="ice.M")
    assert sweep_axes(three, x="flow.u", y="ice.M", at={"impact.e": 0.9}) == ("flow.u", "ice.M")
    chosen = select_rows(three, {"impact.e": 0.9})
    assert len(chosen) == 4 and {r["impact.e"] for r in chosen} == {1.0}


LOAD_CASES = """case,hours,del_m3_1Hz_N,del_m4_1Hz_N,del_m5_1Hz_N,del_m10_1Hz_N,damage_share_m4
thin ice,400,120.5,150.2,170.1,230.4,0.1
midwinter,1200,260.0,300.5,330.2,410.9,0.72
break-up,150,310.2,360.1,400.3,520.0,0.18
"""


def test_plot_load_case_result(tmp_path: Path, capsys) -> None:
    """The load-case layout assumed: per case its name, hours, the 1 Hz DEL per Wöhler exponent
    and its share of the lifetime damage."""
    table = tmp_path / "seasons.csv"
    table.write_text(LOAD_CASES)
    assert main(["plot", str(table)]) == 0
    assert "load cases" in capsys.readouterr().out
    png = table.with_suffix(".png")
    with open(table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    fig = plot_load_cases(rows, tmp_path / "again.png")
    assert png_size(png) == png_size(tmp_path / "again.png") == expected_size(fig)
    share, dels = fig.get_axes()
    assert share.get_xlabel() == "share of the lifetime damage (%)"
    assert dels.get_xlabel() == "1 Hz damage-equivalent load of k x (N)"
    assert [t.get_text() for t in share.get_yticklabels()] == [
        "thin ice (400 h)", "midwinter (1200 h)", "break-up (150 h)"]
    widths = [p.get_width() for p in share.patches]
    assert widths == pytest.approx([10.0, 72.0, 18.0])  # fractions shown in percent
    assert len(dels.patches) == 3 * 4  # a bar per case and exponent

    # a JSON result with its cases inside
    doc = tmp_path / "seasons.json"
    doc.write_text('{"cases": [{"case": "a", "hours": 1, "del_m4_1Hz_N": 2.0, '
                   '"damage_share": 1.0}]}')
    fig, path, kind = plot_table(doc)
    assert kind == "cases" and png_size(path) == expected_size(fig)

    err_table = tmp_path / "other.csv"
    err_table.write_text("a,b\n1,2\n")
    with pytest.raises(PlotError, match="neither a sweep table.*case name column"):
        plot_table(err_table)
    with pytest.raises(PlotError, match="apply to sweep tables"):
        plot_table(table, columns=["x_peak_m"])


def test_plot_an_openfast_out_file(tmp_path: Path) -> None:
    out = tmp_path / "run.out"
    assert main(["simulate", "--t-end", "6", "--dt", "0.01", "--out", str(out)]) == 0
    fig, path, kind = plot_table(out)
    assert kind == "run" and path == tmp_path / "run.png"
    assert png_size(path) == (1100, 1200)
    assert fig.get_axes()[0].get_title() == "Figure 2 scene: structure displacement"


SEASON = """\
t_end = 4.0
transient = 1.0
dt = 0.01
[[case]]
name = "slow drift"
hours = 300.0
"flow.u" = 0.1
[[case]]
name = "fast floe"
hours = 100.0
"flow.u" = 0.5
"""


def test_plot_the_result_of_iceimpact_loads(tmp_path: Path, capsys) -> None:
    """PREFIX.json of ``iceimpact loads`` (or the PREFIX.csv beside it): per case its share of
    the lifetime damage and its DELs, the lifetime DELs as dashed lines."""
    cases = tmp_path / "cases.toml"
    cases.write_text(SEASON)
    prefix = tmp_path / "season"
    assert main(["loads", str(cases), "--life", "25", "--out", str(prefix), "--workers", "1",
                 "--quiet"]) == 0
    summary = json.loads(prefix.with_suffix(".json").read_text())
    fig, path, kind = plot_table(prefix.with_suffix(".json"))
    assert kind == "cases" and png_size(path) == expected_size(fig)
    share, dels = fig.get_axes()
    assert [t.get_text() for t in share.get_yticklabels()] == [
        "slow drift (300 h/yr)", "fast floe (100 h/yr)"]
    m4 = sorted(summary["settings"]["exponents"]).index(4)
    n = len(summary["cases"])
    bars = share.patches[m4 * n:(m4 + 1) * n]
    assert [b.get_width() for b in bars] == pytest.approx(
        [100.0 * c["damage_share"]["4"] for c in summary["cases"]])
    bars = dels.patches[m4 * n:(m4 + 1) * n]
    assert [b.get_width() for b in bars] == pytest.approx(
        [c["del_1Hz_N"]["4"] for c in summary["cases"]])
    lifetime = [line.get_xdata()[0] for line in dels.get_lines()]
    assert lifetime == pytest.approx(list(summary["lifetime"]["del_1Hz_N"].values()))
    assert share.get_xlabel().endswith("(%)") and dels.get_xlabel().endswith("(N)")
    # the runs' table beside it plots the same, from the summary
    capsys.readouterr()
    assert main(["plot", str(prefix.with_suffix(".csv")), "--out", str(tmp_path / "b.png")]) == 0
    assert "load cases" in capsys.readouterr().out
    err = usage_error(capsys, ["plot", str(prefix.with_suffix(".csv")), "--column", "x_peak_m"])
    assert "load-case result" in err
