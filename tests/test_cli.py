"""The ``iceimpact`` command: argument errors, simulate, sweep, the installed entry point,
and a sweep killed half-way then resumed (killed or interrupted while it waits at a known run,
by the sweep's test hook :data:`iceimpact.sweep.PAUSE_ENV`: no race with the clock)."""

from __future__ import annotations

import math
import os
import selectors
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cli_helpers import rows_of, usage_error
from iceimpact import Scene, run
from iceimpact.cli import main
from iceimpact.studies.analysis import summarize
from iceimpact.sweep import PAUSE_ENV, meta_path, read_table, sweep

SCRIPT = Path(sys.executable).with_name("iceimpact")
FAST = ["--t-end", "4", "--dt", "0.01"]


@pytest.fixture
def scene_file(tmp_path: Path) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text('"impact.e" = 0.8\n[ice]\nM = 800.0\n[drag]\nmodel = 2\n')
    return path


#: Argument errors of every subcommand and the words their message must hold.
ARGUMENT_ERRORS = [
    (["sweep", "--vary", "ice.mass=1,2", "--out", "x.csv"], "unknown parameter 'ice.mass'"),
    (["sweep", "--vary", "flow.u=0:1", "--out", "x.csv"], "--vary 'flow.u=0:1'"),
    (["sweep", "--vary", "flow.u=log:0:1:4", "--out", "x.csv"], "nonzero"),
    (["sweep", "--vary", "flow.u=1,2", "--vary", "flow.u=3", "--out", "x.csv"],
     "already varied"),
    (["sweep", "--out", "x.csv"], "--vary"),
    (["sweep", "--vary", "flow.u=1,2"], "--out"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--workers", "0"], "--workers"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--t-end", "-1"], "--t-end"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--t-end", "5", "--transient", "5"],
     "--transient"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--set", "ice.M=-3"],
     "ice.M = -3.0 is not allowed"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--set", "ice.M"], "--set 'ice.M'"),
    (["sweep", "missing.toml", "--vary", "flow.u=1", "--out", "x.csv"],
     "scene file 'missing.toml' not found"),
    (["simulate", "--set", "foo=1"], "unknown parameter 'foo'"),
    (["frobnicate"], "invalid choice"),
]


def test_bad_scene_file_is_an_argument_error(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('"impact.e" = 2.0\n')
    assert "impact.e = 2.0 is not allowed" in usage_error(capsys, ["simulate", str(bad)])
    bad.write_text("ice = [\n")
    assert "bad.toml" in usage_error(capsys, ["simulate", str(bad)])


def test_simulate_writes_samples_and_prints_the_summary(capsys, tmp_path, scene_file):
    out, impacts = tmp_path / "samples.csv", tmp_path / "impacts.csv"
    code = main(["simulate", str(scene_file), "--set", "flow.u=0.2", *FAST, "--transient", "1",
                 "--out", str(out), "--impacts", str(impacts)])
    assert code == 0
    scene = Scene(impact_e=0.8, ice_M=800.0, drag_model=2, flow_u=0.2)
    result = run(scene, 4.0, dt=0.01)
    summary = summarize(result, 1.0)
    text = capsys.readouterr().out
    assert f"{len(result.impacts)} impacts" in text
    assert f"x_peak_m               {summary['x_peak_m']:.6g} m" in text
    samples = rows_of(out)
    assert samples[0] == ["time", "structure.x", "structure.v", "ice.z", "ice.v", "contact.gap",
                          "contact.penetration", "contact.impulse", "contact.active"]
    assert len(samples) == 1 + result.t.size
    assert float(samples[-1][1]) == result.x[-1]
    assert len(rows_of(impacts)) == 1 + len(result.impacts)


def test_sweep_subcommand_matches_the_api(capsys, tmp_path, scene_file):
    out = tmp_path / "sweep.csv"
    code = main(["sweep", str(scene_file), "--vary", "flow.u=0.1:0.3:2",
                 "--vary", "impact.e=0.5,1.5", *FAST, "--transient", "1", "--out", str(out),
                 "--workers", "2", "--quiet", "--set", "ice.A=2"])
    assert code == 1  # runs failed
    captured = capsys.readouterr()
    assert "4 runs (2 ok, 2 errors)" in captured.out
    assert "impact.e = 1.5 is not allowed" in captured.out
    # --quiet: no progress bar, only the failure count
    assert captured.err.startswith("iceimpact sweep: 2 of 4 runs failed")
    base = Scene(impact_e=0.8, ice_M=800.0, drag_model=2, ice_A=2.0)
    expected = sweep(base, {"flow.u": [0.1, 0.3], "impact.e": [0.5, 1.5]}, t_end=4.0,
                     transient=1.0, dt=0.01, workers=1, progress=False)
    got = read_table(out)
    assert len(got) == 4
    for a, b in zip(got, expected, strict=True):
        for key, value in b.items():
            if key != "wall_s" and not (isinstance(value, float) and math.isnan(value)):
                assert a[key] == value, key
    # the same command again resumes a complete table: nothing to run, same file
    before = out.read_text()
    assert main(["sweep", str(scene_file), "--vary", "flow.u=0.1:0.3:2",
                 "--vary", "impact.e=0.5,1.5", *FAST, "--transient", "1", "--out", str(out),
                 "--quiet", "--set", "ice.A=2", "--allow-failures"]) == 0
    assert out.read_text() == before
    # a different grid into the same file is refused, then accepted with --overwrite
    err = usage_error(capsys, ["sweep", "--vary", "flow.u=0.1", *FAST, "--out", str(out)])
    assert "different sweep" in err and "--overwrite" in err
    assert main(["sweep", "--vary", "flow.u=0.1", *FAST, "--out", str(out), "--quiet",
                 "--overwrite"]) == 0
    assert len(read_table(out)) == 1


def test_entry_point_script(tmp_path):
    assert SCRIPT.exists(), "install the package: pip install -e ."
    out = tmp_path / "sweep.csv"
    proc = subprocess.run([str(SCRIPT), "sweep", "--vary", "flow.u=log:0.05:0.5:3", *FAST,
                           "--out", str(out), "--workers", "2"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "3 runs (3 ok, 0 errors)" in proc.stdout
    assert "3/3" in proc.stderr  # the progress bar goes to stderr
    table = rows_of(out)
    assert table[0][:2] == ["run", "flow.u"]
    values = [float(r[1]) for r in table[1:]]
    assert values[0] == 0.05 and values[2] == 0.5
    assert values[1] == pytest.approx(math.sqrt(0.05 * 0.5), rel=1e-12)
    proc = subprocess.run([str(SCRIPT), "sweep", "--vary", "flow.u=0:1", "--out", str(out)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "--vary 'flow.u=0:1'" in proc.stderr and "Traceback" not in proc.stderr


def paused_env(runs: int) -> dict[str, str]:
    """The environment of a sweep that waits after ``runs`` runs (the sweep's test hook)."""
    return {**os.environ, PAUSE_ENV: str(runs)}


def plain_env() -> dict[str, str]:
    """The environment without the test hook (a rerun that must finish)."""
    return {k: v for k, v in os.environ.items() if k != PAUSE_ENV}


def wait_for_pause(proc: subprocess.Popen, timeout: float = 120.0) -> str:
    """Read the command's stderr until the sweep says it has paused; returns what was read.
    Fails if the command ends first, or says nothing of a pause within ``timeout`` s (a bound
    for a broken sweep: the pause itself waits for the test, not for the clock)."""
    text = b""
    deadline = time.monotonic() + timeout
    with selectors.DefaultSelector() as selector:
        selector.register(proc.stderr, selectors.EVENT_READ)
        while b"paused after" not in text:
            left = deadline - time.monotonic()
            assert left > 0 and selector.select(left), f"no pause in {timeout} s: {text!r}"
            chunk = os.read(proc.stderr.fileno(), 65536)
            assert chunk, f"the command ended without pausing: {text!r}"
            text += chunk
    return text.decode()


def test_killed_sweep_resumes_to_the_complete_table(tmp_path):
    """Kill the command (SIGKILL) while it waits after 2 runs, rerun it: all runs, once each."""
    out = tmp_path / "sweep.csv"
    argv = [str(SCRIPT), "sweep", "--vary", "flow.u=0.05:0.5:4", "--vary", "impact.e=0.6,1",
            "--t-end", "30", "--dt", "0.002", "--out", str(out), "--workers", "1",
            "--chunksize", "1", "--quiet"]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env=paused_env(2))
    try:
        assert "paused after 2 runs" in wait_for_pause(proc)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stderr.close()
    partial = read_table(out)
    assert [r["run"] for r in partial] == [0, 1]  # one worker, one run per task: in order
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=120, env=plain_env())
    assert proc.returncode == 0, proc.stderr
    table = rows_of(out)
    assert [r[0] for r in table[1:]] == [str(i) for i in range(8)]
    rows = read_table(out)
    assert all(r["status"] == "ok" for r in rows)
    for old in partial:  # rows written before the kill are kept as they were
        assert rows[old["run"]]["wall_s"] == old["wall_s"]
    # and the resumed table equals one direct run of the missing points
    missing = [r for r in rows if r["run"] not in {p["run"] for p in partial}]
    for row in missing[:1]:
        scene = Scene(flow_u=row["flow.u"], impact_e=row["impact.e"])
        expected = summarize(run(scene, 30.0, dt=0.002), 0.0)
        assert row["x_peak_m"] == expected["x_peak_m"]
        assert row["n_impacts"] == expected["n_impacts"]


def _interruptible() -> None:
    """In the child before it runs: SIGINT back to its default action. A shell starts a
    background job with SIGINT ignored, which the child would inherit (Python then installs no
    KeyboardInterrupt handler), and the sweep would run to its end."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_interrupt_reports_how_to_resume(tmp_path):
    """Ctrl-C (SIGINT) while the sweep waits after its first run: exit 130, the run kept."""
    out = tmp_path / "sweep.csv"
    proc = subprocess.Popen([str(SCRIPT), "sweep", "--vary", "flow.u=0.05:0.5:20", "--t-end",
                             "30", "--out", str(out), "--workers", "1", "--chunksize", "1",
                             "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=_interruptible, env=paused_env(1))
    try:
        before = wait_for_pause(proc)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == 130
    assert "rerun the same command to resume" in before + err.decode()
    assert [r["run"] for r in read_table(out)] == [0]


# Bad input ---------------------------------------------------------------------------------------
#: Hostile arguments (huge grids, numbers that overflow, near-miss names) and their message.
HOSTILE_ARGUMENTS = [
    (["sweep", "--vary", "flow.u=0:1:1000000000", "--out", "x.csv"],
     "COUNT 1,000,000,000 is more than the 100,000 runs"),
    (["sweep", "--vary", "flow.u=0:1:1000", "--vary", "ice.M=1:2:1000", "--out", "x.csv"],
     "the grid has 1,000,000 runs (1,000 x 1,000), more than the limit of 100,000"),
    (["sweep", "--vary", "flow.u=0:1:20", "--out", "x.csv", "--max-runs", "10"],
     "COUNT 20 is more than the 10 runs"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--max-runs", "1e400"],
     "argument --max-runs: '1e400' is not an integer"),
    (["simulate", "--set", "ice.M=1e400"], "--set 'ice.M=1e400': '1e400' is not finite"),
    (["sweep", "--vary", "flow.u=0:1e309:3", "--out", "x.csv"], "'1e309' is not finite"),
    (["simulate", "--t-end", "1e400"], "--t-end: '1e400' must be a finite number > 0"),
    (["simulate", "--set", "solver.method=1e30"], "solver.method = 1e+30 is not allowed"),
    (["simulate", "--t-end", "1e6", "--dt", "1e-9"], "samples per run"),
    (["sweep", "--vary", "flow.u=1", "--out", "x.csv", "--t-end", "1e7", "--dt", "1e-3"],
     "samples per run"),
    (["simulate", "--set", "ice.mass=3"], "unknown parameter 'ice.mass' (did you mean 'ice.M'"),
    (["sweep", "--vary", "impact.E=0,1", "--out", "x.csv"], "(did you mean 'impact.e'?)"),
]


@pytest.mark.parametrize("argv,words", ARGUMENT_ERRORS + HOSTILE_ARGUMENTS)
def test_argument_errors_exit_2_with_a_message(capsys, tmp_path, monkeypatch, argv, words):
    """Every argument error exits with status 2 and one message, before anything is written."""
    monkeypatch.chdir(tmp_path)
    err = usage_error(capsys, argv)
    assert words in err
    assert not (tmp_path / "x.csv").exists()


def test_simulate_titles_the_summary_by_what_was_simulated(capsys, scene_file):
    assert main(["simulate", *FAST]) == 0
    assert capsys.readouterr().out.startswith("Figure 2 scene: 4 s simulated")
    assert main(["simulate", *FAST, "--set", "ice.A=2", "--set", "flow.u=0.2"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("Figure 2 defaults with ice.A = 2, flow.u = 0.2: ")
    assert "Figure 2 scene" not in text
    assert main(["simulate", str(scene_file), *FAST]) == 0
    assert capsys.readouterr().out.startswith(f"{scene_file}: ")
    assert main(["simulate", str(scene_file), *FAST, "--set", "ice.A=2"]) == 0
    assert capsys.readouterr().out.startswith(f"{scene_file} with ice.A = 2: ")


def test_simulate_columns_are_the_fmu_output_names():
    """The sample columns are outputs of the FMU (the contract's OUTPUTS), plus the time."""
    from iceimpact.cli import SAMPLE_COLUMNS
    from iceimpact.contract import OUTPUTS

    fields = {out.name: out.field for out in OUTPUTS}
    for name, field in SAMPLE_COLUMNS[1:]:
        assert fields[name] == field, name
    assert SAMPLE_COLUMNS[0] == ("time", "t")


def test_simulate_does_not_import_the_sweep(tmp_path):
    code = ("import sys\nfrom iceimpact.cli import main\n"
            "main(['simulate', '--t-end', '1', '--dt', '0.01'])\n"
            "print('iceimpact.sweep' in sys.modules)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().endswith("False")


def test_failed_runs_exit_1_unless_allowed(tmp_path):
    out = tmp_path / "sweep.csv"
    argv = [str(SCRIPT), "sweep", "--vary", "impact.e=0.5,1.5,2", *FAST, "--out", str(out),
            "--workers", "1", "--quiet"]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert "iceimpact sweep: 2 of 3 runs failed" in proc.stderr
    assert "Traceback" not in proc.stderr
    proc = subprocess.run([*argv, "--allow-failures"], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "3 runs (1 ok, 2 errors)" in proc.stdout


def test_a_damaged_journal_exits_2_and_keeps_the_table(capsys, tmp_path):
    out = tmp_path / "sweep.csv"
    argv = ["sweep", "--vary", "flow.u=0.1,0.2,0.3", *FAST, "--out", str(out), "--quiet",
            "--workers", "1"]
    assert main(argv) == 0
    damaged = out.read_text().replace("\n1,", "\n1,,")
    out.write_text(damaged)
    err = usage_error(capsys, argv)
    assert f"{out}: line 3 has" in err and "nothing was changed" in err
    assert out.read_text() == damaged
    meta_path(out).write_text('{"format": "iceimpact-sweep", "format_ver')
    err = usage_error(capsys, argv)
    assert "sweep.csv.meta.json: is not valid JSON" in err
    assert out.read_text() == damaged


def descendants(pid: int) -> set[int]:
    """PIDs of the live descendants of ``pid`` (from /proc)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def alive(pid: int) -> bool:
    """Running (not gone, not a zombie waiting to be reaped)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killed_sweep_leaves_no_workers_and_resumes(tmp_path):
    """SIGKILL the command while it waits after 3 runs with its 2 pool workers up: they die
    too; a rerun completes."""
    out = tmp_path / "sweep.csv"
    argv = [str(SCRIPT), "sweep", "--vary", "flow.u=0.05:0.5:12", "--t-end", "30", "--dt",
            "0.002", "--out", str(out), "--workers", "2", "--chunksize", "1", "--quiet"]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env=paused_env(3))
    try:
        assert "paused after 3 runs" in wait_for_pause(proc)
        workers = descendants(proc.pid)  # the pool is up while the sweep waits
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stderr.close()
    assert len(workers) >= 2, "no pool workers seen"
    partial = read_table(out)
    assert len(partial) == 3
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(alive(pid) for pid in workers):
        time.sleep(0.05)
    assert not [pid for pid in workers if alive(pid)], "orphan workers survived"
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=180, env=plain_env())
    assert proc.returncode == 0, proc.stderr
    rows = read_table(out)
    assert [r["run"] for r in rows] == list(range(12))
    assert all(r["status"] == "ok" for r in rows)
    for old in partial:  # rows written before the kill are kept as they were
        new = rows[old["run"]]
        assert new.keys() == old.keys()
        assert all(new[k] == v or (v != v and new[k] != new[k]) for k, v in old.items())
