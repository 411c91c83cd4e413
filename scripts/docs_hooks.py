"""MkDocs hooks of the documentation site: the reference pages made from the code at every build.

``mkdocs.yml`` names this file under ``hooks:``. At each build :func:`on_files` adds pages that
exist in no file of ``docs/``:

- ``reference/fmu-variables.md``: the tables of :mod:`iceimpact.contract` and
  :mod:`iceimpact.modal.contract` (:func:`fmu_variables_page`);
- ``reference/cli.md``: every command and option of ``iceimpact``, read from the argument parser
  (:func:`iceimpact.cli.build_parser`; :func:`cli_page`);
- ``reference/limits.md``: the constants of :mod:`iceimpact.limits` with their comments, and its
  rules (:func:`limits_page`);
- ``reference/errors.md``: the messages a user meets, each made by running the code that
  raises it (:func:`errors_page`);
- ``measurements/``: one page per table under ``benchmarks/results/`` and the JSON files
  beside them (:func:`measurement_pages`).

Every function here returns Markdown and can be called without MkDocs (the tests do).

The pages are also committed under ``docs/``, so that a link to them resolves in the source
tree as well as on the site: ``python scripts/docs_hooks.py --write`` rewrites the copies that
differ, ``python scripts/docs_hooks.py`` exits 1 if one does, and the build fails on a stale
copy (``tests/docs/test_links.py`` checks both).
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import math
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

#: Generated page -> the function that writes it.
PAGES: dict[str, Callable[[], str]] = {}


def page(uri: str) -> Callable[[Callable[[], str]], Callable[[], str]]:
    def register(make: Callable[[], str]) -> Callable[[], str]:
        PAGES[uri] = make
        return make
    return register


def _cell(text: Any) -> str:
    """Text for a Markdown table cell: no line breaks, no bare pipes."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _fence(text: str) -> str:
    return "```text\n" + text.rstrip("\n") + "\n```"


# --- FMU variables ---------------------------------------------------------------------------
def _variables(table: str) -> str:
    """A Markdown table of variables in ``<div class="variables">``, which
    ``docs/stylesheets/variables.css`` lays out: names unbroken, the meaning column wrapped."""
    return f'<div class="variables" markdown>\n\n{table}\n</div>\n'


@page("reference/fmu-variables.md")
def fmu_variables_page() -> str:
    """Every variable of IceImpact.fmu and ModalStructure.fmu, from their contract tables."""
    from iceimpact import contract
    from iceimpact.modal import contract as modal

    exp = contract.DEFAULT_EXPERIMENT
    # the table of contents is hidden: its two entries cost the seven columns a third of the page
    return f"""---
hide:
  - toc
---

# FMU variables

This page lists every variable of `IceImpact.fmu` and `ModalStructure.fmu`: name, causality,
type, unit, start value, allowed range and meaning. It is generated from the contract tables
`iceimpact.contract` and `iceimpact.modal.contract` at every build of this site, so it is the
interface of the code it was built from.

## IceImpact.fmu

FMI 2.0 Co-Simulation, model identifier `{contract.MODEL_IDENTIFIER}`, version {contract.VERSION}.
Units are SI; `1` is dimensionless. The defaults are the article's Figure 2 scene; the
DefaultExperiment runs from {contract.number_text(exp.start_time)} to
{contract.number_text(exp.stop_time)} s at steps of {exp.step_size:g} s.
`python build_fmu.py --variables-table` prints the same table from a built FMU.

{_variables(contract.markdown_table())}
The XML carries `min`/`max` where the range has a bound (FMI bounds are inclusive: "> 0" is
written `min="0"`, the FMU itself refuses 0). Every Real has its unit in `UnitDefinitions`,
every output its dependencies in `ModelStructure` ([IceImpact.fmu](fmu.md)).

## ModalStructure.fmu

FMI 2.0 Co-Simulation, model identifier `{modal.MODEL_IDENTIFIER}`: a linear structure of up to
five modes seen at one contact point ([how it is coupled](../explanation/coupling.md)). FMI 2.0
has no arrays: modes 1 to 5 have six parameters each, and `modes` says how many are used (the
others are ignored and not validated). The defaults are one mode equal to IceImpact's built-in
structure (m = 1600 kg, c = 200 N·s/m, k = 1e6 N/m: `f = 3.9789 Hz`, `ζ = 0.0025`); modes 2 to 5
default to the same values with `phi = 0`, so switching one on without setting it does not move
the contact point.

{_variables(modal.markdown_table())}
Initial conditions are per mode (`q0`, `v0`): with several modes a displacement of the contact
point alone does not fix the modal state.
"""


# --- command line ----------------------------------------------------------------------------
def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _option_rows(parser: argparse.ArgumentParser) -> list[str]:
    rows = ["| argument | value | default | meaning |", "|---|---|---|---|"]
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        name = (", ".join(f"`{s}`" for s in action.option_strings)
                or f"`{action.metavar or action.dest}`")
        if action.option_strings and action.nargs == 0:
            value = ""
        elif action.choices is not None:
            value = " \\| ".join(f"`{c}`" for c in action.choices)
        else:
            value = f"`{action.metavar or action.dest.upper()}`"
        if isinstance(action, argparse._AppendAction):
            value += " (repeatable)"
        if action.required and action.option_strings:
            value += " (required)"
        default = action.default
        shown = "" if default in (None, False, [], argparse.SUPPRESS) or action.nargs == 0 \
            else f"`{default}`"
        rows.append(f"| {name} | {value} | {shown} | {_cell(action.help or '')} |")
    return rows


@page("reference/cli.md")
def cli_page() -> str:
    """Every command and option of ``iceimpact``, from its argument parser."""
    from iceimpact.cli import EXIT_RUNS_FAILED, build_parser

    parser = build_parser()
    parts = ["# Command line", "",
             "This page lists every command of `iceimpact` with its options, defaults and "
             "meaning. It is generated from the argument parser of `iceimpact/cli.py` "
             "(`build_parser()`) at every build, so it is what `iceimpact COMMAND --help` "
             "prints.", "",
             f"`iceimpact` is installed with the package (`pip install -e .`). "
             f"{_cell(parser.description)}", "",
             "```text", parser.format_usage().strip(), "```", "",
             "## Exit statuses", "",
             "| status | meaning |", "|---|---|",
             "| 0 | done |",
             f"| {EXIT_RUNS_FAILED} | `sweep`, `loads`: the table is complete but some runs failed "
             "(their status column holds the error; `--allow-failures` makes it 0), or a worker "
             "process died (rerun to resume) |",
             "| 2 | an argument error: a bad option, value, scene file, grid or table; one line "
             "`iceimpact COMMAND: error: ...`, no traceback, nothing run or written; "
             "`simulate`: also a refused step (the message names the setting to change) |",
             "| 130 | interrupted (Ctrl-C, SIGTERM); `sweep` and `loads` resume when rerun |", ""]
    for name, sub in _subparsers(parser).items():
        parts += [f"## iceimpact {name}", "", _cell(sub.description or ""), "",
                  "```text", sub.format_usage().strip(), "```", "",
                  *_option_rows(sub), ""]
    parts += ["Names of parameters (`--set`, `--vary`) are the FMU's: see "
              "[FMU variables](fmu-variables.md). Messages of refused values: "
              "[Error messages](errors.md).", ""]
    return "\n".join(parts)


# --- limits ----------------------------------------------------------------------------------
def _commented_constants(path: Path) -> list[tuple[str, str]]:
    """(name, comment) of every module-level constant that a ``#:`` comment describes."""
    lines = path.read_text().splitlines()
    found = []
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                and isinstance(node.targets[0], ast.Name):
            comment, i = [], node.lineno - 2
            while i >= 0 and lines[i].lstrip().startswith("#:"):
                comment.insert(0, lines[i].lstrip()[2:].strip())
                i -= 1
            name = node.targets[0].id
            if comment and not name.startswith("_"):
                found.append((name, " ".join(comment)))
    return found


def _value_text(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}" if value and (abs(value) >= 1e5 or abs(value) < 1e-3) else repr(value)
    if isinstance(value, dict):
        return ", ".join(f"{k} = {v}" for k, v in value.items())
    return repr(value) if isinstance(value, str) else str(value)


@page("reference/limits.md")
def limits_page() -> str:
    """The constants and rules of :mod:`iceimpact.limits`."""
    import iceimpact.limits as limits

    rows = ["| constant | value | what it bounds, and the measurement behind it |",
            "|---|---|---|"]
    for name, comment in _commented_constants(Path(limits.__file__)):
        rows.append(f"| `{name}` | `{_cell(_value_text(getattr(limits, name)))}` | "
                    f"{_cell(comment)} |")
    return "\n".join([
        "# Limits", "",
        "This page lists what a scene may ask of each solver method so that a simulated second "
        "costs bounded work: the constants of `iceimpact.limits` and the rules that apply them. "
        "It is generated from that module at every build; why each limit sits where it does, "
        "with the measurements, is in [Why the limits are where they are]"
        "(../explanation/robustness/limits.md).", "",
        "Validation (`iceimpact.scene.validate`, hence `Scene(...)`, the FMU at initialization "
        "and the CLI) calls these rules; a refusal is a `ParameterError` naming the "
        "combination, its value, the limit and what to change ([Error messages](errors.md) "
        "shows each). Besides these, each parameter has its range "
        "([FMU variables](fmu-variables.md)) and a step may make at most `solver.max_impacts` "
        "impacts and, with method 3, `solver.max_evaluations` evaluations.", "",
        "## Constants", "", *rows, "",
        "## Rules", "",
        "The formulas each rule evaluates, from the functions' docstrings:", "",
        "::: iceimpact.limits",
        "    options:",
        "      members: [check_work, rate_limit, omega_limit, sticking_rates, "
        "check_sticking_rate, integrated_rate, check_structure_drag_rate, drag_rate, "
        "integrates_quadratic_drag, integrates_taylor_sticking]",
        "      show_root_heading: false",
        "      show_source: false",
        "      heading_level: 3", ""])


# --- error messages --------------------------------------------------------------------------
def _message(make: Callable[[], Any], *errors: type[BaseException]) -> str:
    """The message of the error ``make`` raises; an error if it raises none (the page would
    document a refusal the code no longer makes)."""
    try:
        make()
    except errors as exc:
        return str(exc)
    raise AssertionError(f"{make} raised none of {errors}")


def _bad_value(var: Any) -> Any:
    """A value outside a contract variable's range (for its message)."""
    if var.choices:
        return max(var.choices) + 1
    if var.minimum is not None:
        if var.min_exclusive:
            return var.minimum
        if var.kind is int or var.minimum <= 0:
            return var.minimum - 1
        return var.minimum / 10
    if var.maximum is not None:
        return var.maximum + 1
    return math.inf


#: (situation, FMI values of the scene, what to change): combinations validation refuses.
SCENE_CASES: tuple[tuple[str, dict[str, Any], str], ...] = (
    ("the ice starts downstream of the structure", {"ice.z0": 0.01},
     "start the ice upstream: `ice.z0 <= structure.x0`"),
    ("an external structure with method 2 or 3", {"structure.model": 2, "solver.method": 2},
     "use `solver.method = 1` with `structure.model = 2`"),
    ("Morison loads on an external structure",
     {"structure.model": 2, "structure.Ca": 1.0, "structure.V": 1.0},
     "leave `structure.Ca`, `V`, `Cd`, `A` at 0: the other FMU models the structure's fluid loads"),
    ("quadratic drag on the structure with method 2",
     {"solver.method": 2, "drag.model": 2, "structure.Cd": 1.0, "structure.A": 1.0},
     "method 1 or 3, or `drag.model = 1`"),
    ("scales that overflow: stiffness over mass", {"structure.k": 1e300, "structure.m": 1e-10},
     "values whose ratios are finite numbers: a physical scene"),
    ("scales that underflow: the damping ratio", {"structure.k": 1e-200, "structure.m": 1e-200},
     "values whose products are finite and nonzero"),
    ("scales that overflow: the drag constant", {"fluid.rho": 1e300, "ice.A": 1e300},
     "a drag constant `rho Cd A / 2` within double precision"),
    ("scales that overflow: an initial energy", {"ice.v0": 1e200},
     "initial states whose energies are finite"),
    ("method 1, a structure too stiff for the root search", {"structure.k": 1e40},
     "`omega_n <= 7.06e7` rad/s (a stiffness below `m (7.06e7)^2`), or method 2"),
    ("method 3, a structure too stiff for the integrators",
     {"solver.method": 3, "structure.k": 1.6e12}, "method 1 or 2, or a softer structure"),
    ("method 3 with Radau, a stiff structure",
     {"solver.method": 3, "solver.ode_method": 4, "structure.k": 1.6e11},
     "LSODA (`solver.ode_method = 3`), or a looser `solver.rtol`, or method 1 or 2"),
    ("method 3 with Radau, a tight tolerance",
     {"solver.method": 3, "solver.ode_method": 4, "solver.rtol": 1e-12},
     "`solver.rtol >= 1e-10`, or LSODA"),
    ("method 1, linear drag faster than the root search's time resolution",
     {"drag.v_lin": 1e20}, "method 2, or a drag rate `b / M <= 1.12e15` 1/s"),
    ("method 3, a linear drag rate beyond the explicit integrators'", {"solver.method": 3,
     "ice.M": 1e-4}, "LSODA (`solver.ode_method = 3`, up to 1e6 1/s), or method 1 or 2"),
    ("method 3, a quadratic drag rate beyond the explicit integrators'",
     {"solver.method": 3, "drag.model": 2, "flow.u": 1e6},
     "LSODA, a slower flow, or a heavier floe"),
    ("method 1, a quadratic-drag sticking phase too stiff for its Taylor steps",
     {"drag.model": 2, "flow.u": 5e5}, "`drag.model = 1` (closed-form sticking), or a slower "
     "flow, or a softer structure"),
    ("method 3, a structure damped beyond the explicit integrators'",
     {"solver.method": 3, "structure.c": 1e9}, "method 1 or 2, or LSODA"),
    ("method 3, a Morison drag on the structure beyond the explicit integrators'",
     {"solver.method": 3, "structure.Cd": 1.0, "structure.A": 1e7}, "LSODA, or method 1 or 2"),
    ("method 2, an explicit Euler step of the quadratic drag that would diverge",
     {"solver.method": 2, "drag.model": 2, "ice.M": 1e-3},
     "the `solver.dt` the message names, or method 1"),
)


def _scene_error(values: dict[str, Any]) -> str:
    from iceimpact import ParameterError, Scene
    return _message(lambda: Scene.from_fmi(values), ParameterError)


def _step_errors() -> list[tuple[str, str, str]]:
    """(situation, message, what to change) of refused steps, each made by a short run."""
    from iceimpact import ParameterError, Scene, Simulator, SolverError

    quadratic = Simulator(Scene(drag_model=2))
    light_floe = Scene.from_fmi({
        "structure.m": 1.0, "structure.v0": 1.0, "ice.M": 0.01, "ice.A": 1.0, "ice.z0": 0.0,
        "ice.v0": 0.0, "drag.model": 2, "solver.method": 2, "flow.u": 0.0, "impact.e": 0.0})

    def euler_after_impact() -> None:
        sim = Simulator(light_floe)
        for _ in range(100):
            sim.advance(1.9e-4, 0.0)

    return [
        ("`flow.u` not a finite number", _message(lambda: Simulator(Scene()).advance(
            1e-3, math.nan), ParameterError), "a finite flow speed; the step can be retried"),
        ("`flow.u` whose drag force overflows", _message(lambda: Simulator(Scene()).advance(
            1e-3, 1e200), ParameterError), "a physical flow speed"),
        ("`flow.u` beyond a drag-rate limit during a run", _message(
            lambda: quadratic.advance(1e-3, 5e5), ParameterError),
         "a slower flow (the limit is in the message); the run goes on with a valid one"),
        ("a step that needs more impacts than `solver.max_impacts`", _message(
            lambda: Simulator(Scene.from_fmi({"solver.max_impacts": 1})).advance(10.0),
            SolverError), "shorter communication steps (the message gives a length), or a "
         "larger `solver.max_impacts`"),
        ("method 3: a step that needs more evaluations than `solver.max_evaluations`", _message(
            lambda: Simulator(Scene.from_fmi({"solver.method": 3,
                                              "solver.max_evaluations": 3000})).advance(29.0),
            SolverError), "shorter steps, or a larger `solver.max_evaluations`"),
        ("method 2: the Euler step of the quadratic drag would diverge after an impact",
         _message(euler_after_impact, SolverError),
         "the smaller `solver.dt` the message names, or method 1"),
    ]


@contextlib.contextmanager
def _scene_file(text: str | bytes, suffix: str = ".toml") -> Iterator[Path]:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"scene{suffix}"
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        yield path


def _file_errors() -> list[tuple[str, str, str]]:
    from iceimpact import ParameterError, load_scene

    def loaded(text: str | bytes) -> str:
        with _scene_file(text) as path:
            message = _message(lambda: load_scene(path), ParameterError)
            return message.replace(str(path), "scene.toml")

    return [
        ("a file that is not TOML", loaded(b"ice.M = = 1\n"), "fix the TOML syntax"),
        ("a parameter given twice", loaded('"ice.M" = 800.0\n[ice]\nM = 900.0\n'),
         "give each parameter once"),
        ("an unknown name", loaded("[ice]\nmass = 1.0\n"), "the FMU's name (the message "
         "suggests the closest)"),
        ("a number beyond double precision", loaded("[ice]\nM = 1e400\n"),
         "a finite number"),
        ("a value of the wrong type", loaded('[drag]\nmodel = "quadratic"\n'),
         "a number (`drag.model = 2`)"),
    ]


def _cli_errors() -> list[tuple[str, str, str]]:
    from iceimpact.cli import main

    def said(*argv: str) -> str:
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                status = main(list(argv))
            except SystemExit as exc:
                status = exc.code
        assert status == 2, (argv, status)
        return err.getvalue().strip().splitlines()[-1]

    return [
        ("`--set` with a value out of range", said("simulate", "--set", "ice.M=-1"),
         "a value in the range ([FMU variables](fmu-variables.md))"),
        ("`--set` with an unknown name", said("simulate", "--set", "ice.mass=1"),
         "the FMU's name"),
        ("a malformed `--vary`", said("sweep", "--vary", "flow.u=0:1", "--out", "x.csv"),
         "`START:STOP:COUNT`, `log:START:STOP:COUNT` or `a,b,c`"),
        ("a grid beyond `--max-runs`", said("sweep", "--vary", "flow.u=0:1:1000000000",
                                             "--out", "x.csv"),
         "fewer values, or a larger `--max-runs`"),
        ("a time that is not a number", said("simulate", "--t-end", "1e400"),
         "a finite positive number"),
    ]


def _state_errors() -> list[tuple[str, str, str]]:
    from iceimpact import Scene, Simulator, StateError
    from iceimpact.fmi import state

    snapshot = Simulator(Scene()).save()
    altered = {**snapshot, "version": 99}
    return [
        ("`Simulator.from_snapshot` with a field missing",
         _message(lambda: Simulator.from_snapshot({"t": 0.0}), StateError),
         "a record from `Simulator.save()`, unchanged"),
        ("`Simulator.restore` with a field altered",
         _message(lambda: Simulator(Scene()).restore(altered), StateError),
         "a record from `Simulator.save()`, unchanged"),
        ("an FMU state blob that is not one (`fmi2DeSerializeFMUstate`)",
         _message(lambda: state.decode(b"not a state"), StateError),
         "a blob `fmi2SerializeFMUstate` wrote, of this FMU and version"),
    ]


def _table(rows: list[tuple[str, str, str]]) -> list[str]:
    out = ["| situation | message | what to change |", "|---|---|---|"]
    out += [f"| {_cell(a)} | `{_cell(b)}` | {_cell(c)} |" for a, b, c in rows]
    return out


@page("reference/errors.md")
def errors_page() -> str:
    """Every error message a user can meet, made by running the code that raises it."""
    from iceimpact import Scene, contract

    ranges = ["| variable | allowed | message for a value outside |", "|---|---|---|"]
    for var in (*contract.PARAMETERS, *contract.INPUTS):
        bad = _bad_value(var)
        message = _scene_error({var.name: bad})
        ranges.append(f"| `{var.name}` | {_cell(var.allowed)} | `{_cell(message)}` |")
    combos = _table([(what, _scene_error(values), change)
                     for what, values, change in SCENE_CASES])
    del Scene
    return "\n".join([
        "# Error messages", "",
        "This page lists the messages IceImpact gives when it refuses a value, a scene, a step, "
        "a file or a saved state, and what to change in each case. Every message below was "
        "made by running the code that gives it when this site was built, so the wording is "
        "the code's.", "",
        "Every refusal names what is wrong, its value and what is allowed, in one form: "
        "`NAME = VALUE is not allowed: ALLOWED`. In Python it is an exception: "
        "`ParameterError` (a value or a combination), `SolverError` (a step a method cannot "
        "take), `StateError` (a saved state), `SweepError` and `SeasonError` (a sweep or a "
        "load-case table). `ParameterError`, `SolverError` and `StateError` are exported by "
        "`iceimpact`, `SweepError` by `iceimpact.sweep`, `SeasonError` by "
        "`iceimpact.seasons`. A refused step changes nothing: the simulator, and the "
        "FMU, stay as they were before it, and a valid step can follow. How the FMU reports "
        "each refusal (which status, when) is in [IceImpact.fmu](fmu.md#errors); how each "
        "host shows it, in [Run it in each host]"
        "(../how-to/run-in-hosts.md#how-a-host-shows-a-refusal).", "",
        "## A value outside its range", "",
        "Each parameter and input of the [contract](fmu-variables.md) has a range. A value "
        "outside it (in Python, a scene file, `--set`, or an FMU setter) gives:", "",
        *ranges, "",
        "What to change: a value in the range. A Python number that is a `bool`, a string or "
        "complex is refused the same way; numpy integers and floats are taken as the floats "
        "they are.", "",
        "## A scene the methods cannot run", "",
        "Valid values can combine into a scene whose scales overflow double precision, or "
        "that a method cannot resolve in bounded work ([Limits](limits.md)):", "",
        *combos, "",
        "## A refused step", "",
        "A step is refused as a whole and changes nothing (the FMU: `fmi2Discard`; "
        "`iceimpact simulate`: exit status 2):", "",
        *_table(_step_errors()), "",
        "## Scene files", "",
        "`load_scene`, `iceimpact simulate SCENE` and every command that takes a scene file "
        "refuse a file they cannot read whole:", "",
        *_table(_file_errors()), "",
        "## The command line", "",
        "An argument error prints one line and exits with status 2, before anything runs:", "",
        *_table(_cli_errors()), "",
        "Sweep tables and load-case tables that are damaged, another sweep's, or hold a bad "
        "value are refused the same way: [Sweep parameters](../how-to/sweep-parameters.md#"
        "bad-input), [Design over an ice season](../how-to/design-over-a-season.md).", "",
        "## Saved states", "",
        *_table(_state_errors()), "",
    ])


# --- table columns ---------------------------------------------------------------------------
def _fields_table(fields: dict[str, tuple[str, str]]) -> list[str]:
    rows = ["| column | unit | meaning |", "|---|---|---|"]
    rows += [f"| `{name}` | {unit} | {_cell(meaning)} |" for name, (unit, meaning)
             in fields.items()]
    return rows


@page("reference/table-columns.md")
def table_columns_page() -> str:
    """The columns of a run's summary, a sweep table and a load-case table."""
    from iceimpact.seasons import SEASON_FIELDS
    from iceimpact.studies.analysis import SUMMARY_FIELDS
    from iceimpact.studies.loads import LOAD_FIELDS
    from iceimpact.sweep.columns import RUN_COLUMN, STATUS_COLUMN, WALL_COLUMN

    season = {**SEASON_FIELDS, **{k: v for k, v in LOAD_FIELDS.items()
                                  if k not in SEASON_FIELDS}}
    return "\n".join([
        "# Table columns", "",
        "This page lists the columns of a run's summary (`summarize`), of a sweep table "
        "(`iceimpact sweep`) and of a load-case table (`iceimpact loads`), with their units. "
        "It is generated from `SUMMARY_FIELDS`, `LOAD_FIELDS` and `SEASON_FIELDS` at every "
        "build, the lists the code itself writes.", "",
        "Undefined measures are `nan` (fewer than two impacts, a structure at rest, too few "
        "samples for a spectrum, no sticking phase); an error row has none. What the design "
        "loads mean and where they stop being meaningful: [Design loads]"
        "(../explanation/design-loads.md). With the modal structure (`structure.model = 3`) "
        "the `k x` columns are those of `k_c x`, k_c the static stiffness of the contact "
        "point: a quasi-static equivalent load at the ice action point ([The modal structure]"
        "(../explanation/modes.md#the-structural-load-k_c-x)).", "",
        "## A run's summary and a sweep row", "",
        f"A sweep row is `{RUN_COLUMN}` (the run's index in the grid), one column per varied "
        f"parameter (its FMI name and unit), `{STATUS_COLUMN}` (`ok` or the run's error), "
        f"`{WALL_COLUMN}` (the run's wall time, s), then the summary of "
        "`iceimpact.studies.analysis.summarize`, in this order:", "",
        *_fields_table(SUMMARY_FIELDS), "",
        "## A load-case run", "",
        "A row of `iceimpact loads`' table is `run`, `case` (0-based position in the file), "
        "`repetition` (0 = unperturbed), the FMI values of the run, `status` and `wall_s`, then "
        "the loads over the run's window (`iceimpact.seasons.run_columns`):", "",
        *_fields_table(season), ""])


# --- measurements ----------------------------------------------------------------------------
#: File stem prefix -> (title, the command that writes it). The longest matching prefix wins.
RESULT_SOURCES: dict[str, tuple[str, str]] = {
    "core_speed": ("Core speed", "python benchmarks/core_speed.py"),
    "chatter_trade": ("The chatter threshold's trade", "python benchmarks/chatter_trade.py"),
    "count_divergence": ("Where two codes' impact counts part",
                         "python benchmarks/count_divergence.py"),
    "coupling": ("Coupling accuracy against the communication step",
                 "python benchmarks/coupling.py"),
    "implicit_cost": ("Method 3's implicit integrators: cost",
                      "python benchmarks/implicit_cost.py"),
    "pure_opcodes": ("Pure Python path: instructions per impact",
                     "python benchmarks/pure_opcodes.py"),
    "reference_events": ("Reference runs' events against an earlier tree",
                         "python tools/compare_reference_events.py"),
    "work_precision": ("Work-precision study", "python benchmarks/work_precision.py"),
    "work_precision_log": ("Work-precision study: log of its runs",
                           "python benchmarks/work_precision.py"),
    "extremes_matrix": ("The extremes matrix", "python tests/extremes.py"),
    "ode_rate_cost": ("Method 3's explicit integrators: cost against the rate",
                      "python tools/ode_rate_cost.py"),
    "taylor_rate_cost": ("Method 1's Taylor sticking steps: cost against the rate",
                         "python tools/taylor_rate_cost.py"),
    "random_search_runs": ("Random search runs", "python tools/random_search.py"),
    "far_scale_search_runs": ("Far-scale search runs", "python tools/random_search.py --far"),
    "speed_log": ("Speed measurements over the rounds of faster impacts",
                  "python benchmarks/core_speed.py, benchmarks/fmu_overhead.py, "
                  "benchmarks/regime_map_speed.py"),
    "fmu_overhead": ("FMU cost per step", "python benchmarks/fmu_overhead.py"),
    "fmu_state": ("Saved state cost (core)", "python benchmarks/fmu_state.py"),
    "fmu_state_fmi": ("Saved state cost through FMPy", "python benchmarks/fmu_state_fmi.py"),
    "modal_speed": ("The modal structure's cost per impact",
                    "python benchmarks/modal_speed.py"),
    "modal_coupling": ("Modes inside against co-simulation",
                       "python benchmarks/modal_coupling.py"),
    "morison_cost": ("Morison terms off: cost", "python benchmarks/morison_cost.py"),
    "regime_map_speed": ("Regime map end to end", "python benchmarks/regime_map_speed.py"),
    "ringing": ("Stiff ringing scenes: cost", "python benchmarks/ringing.py"),
    "season": ("Season example: cost", "python benchmarks/season.py"),
    "soak": ("Long runs: memory and time per impact", "python benchmarks/soak.py"),
    "standalone_start": ("Standalone FMU start-up", "python benchmarks/standalone_start.py"),
    "startup": ("Start-up of the compiled kernels", "python benchmarks/startup.py"),
    "stick_part_cycle": ("Stick-part cycles: cost", "python benchmarks/stick_part_cycle.py"),
    "sticking_speed": ("Quadratic sticking phase: cost", "python benchmarks/sticking_speed.py"),
    "sweep_speed": ("Sweep runs per second", "python benchmarks/sweep_speed.py"),
}


def result_source(stem: str) -> tuple[str, str]:
    """(title, command) of a results file, from the longest prefix of its stem."""
    best = max((p for p in RESULT_SOURCES if stem.startswith(p)), key=len, default=None)
    if best is None:
        raise KeyError(f"benchmarks/results/{stem}: no entry in RESULT_SOURCES")
    title, command = RESULT_SOURCES[best]
    detail = stem[len(best):].strip("_").replace("_", " ")
    return (f"{title}: {detail}" if detail else title), command


def _first_heading(text: str) -> str | None:
    first = text.lstrip().splitlines()[0] if text.strip() else ""
    return first[2:].strip() if first.startswith("# ") else None


def measurement_pages() -> dict[str, str | bytes]:
    """measurements/<stem>.md for each benchmarks/results/*.md, the JSON files as they are, and
    measurements/index.md listing both."""
    pages: dict[str, str | bytes] = {}
    rows = ["| measurement | written by | files |", "|---|---|---|"]
    stems = sorted({p.stem for p in RESULTS.glob("*.md")} | {p.stem for p in
                                                             RESULTS.glob("*.json")})
    for stem in stems:
        title, command = result_source(stem)
        md, js = RESULTS / f"{stem}.md", RESULTS / f"{stem}.json"
        files = []
        if md.exists():
            text = md.read_text()
            title = _first_heading(text) or title
            pages[f"measurements/{stem}.md"] = (
                f"# {title}\n\nThis page is `benchmarks/results/{stem}.md` of the repository, "
                f"as `{command}` and its runs recorded it. The explanation pages say what it "
                f"shows.\n\n" + _without_title(text))
            files.append(f"[table]({stem}.md)")
        if js.exists():
            pages[f"measurements/{stem}.json"] = js.read_bytes()
            files.append(f"[{stem}.json]({stem}.json)")
        rows.append(f"| {title} | `{command}` | {', '.join(files)} |")
    pages["measurements/index.md"] = "\n".join([
        "# Measurements", "",
        "This page lists every stored measurement of the project: benchmark runs, search runs "
        "and studies, each with the command that writes it. The files live under "
        "`benchmarks/results/` in the repository; the explanation pages quote them.", "",
        "Times are CPU or wall times of one machine (2 cores shared with other work unless a "
        "table says otherwise): compare rows of one table, not tables of different runs. "
        "Counts of steps, evaluations and instructions do not depend on the machine.", "",
        *rows, ""])
    return pages


def _without_title(text: str) -> str:
    lines = text.splitlines()
    if lines and lines[0].startswith("# "):
        lines = lines[1:]
    return "\n".join(lines).lstrip("\n") + "\n"


# --- MkDocs events ---------------------------------------------------------------------------
def generated_pages() -> dict[str, str | bytes]:
    """Every generated file of the site: URI -> content."""
    pages: dict[str, str | bytes] = {uri: make() for uri, make in PAGES.items()}
    pages.update(measurement_pages())
    return pages


DOCS = ROOT / "docs"


def stale_pages(pages: dict[str, str | bytes] | None = None) -> list[str]:
    """The generated pages whose committed copy under docs/ is missing or differs from what the
    code makes today (the copies are committed so that links to them resolve in the source)."""
    pages = generated_pages() if pages is None else pages
    stale = []
    for uri, content in pages.items():
        path = DOCS / uri
        data = content.encode() if isinstance(content, str) else content
        if not path.is_file() or path.read_bytes() != data:
            stale.append(uri)
    return stale


def write_pages() -> list[str]:
    """Write every generated page under docs/ where it is missing or differs; returns those."""
    pages = generated_pages()
    changed = stale_pages(pages)
    for uri in changed:
        path = DOCS / uri
        path.parent.mkdir(parents=True, exist_ok=True)
        content = pages[uri]
        path.write_bytes(content.encode() if isinstance(content, str) else content)
    return changed


def on_files(files: Any, config: Any) -> Any:
    """The committed copies are the pages: the build fails if one differs from the code's."""
    from mkdocs.exceptions import PluginError
    from mkdocs.structure.files import File

    pages = generated_pages()
    stale = stale_pages(pages)
    if stale:
        raise PluginError("generated pages differ from the code (regenerate: python "
                          "scripts/docs_hooks.py --write): " + ", ".join(sorted(stale)))
    for uri, content in pages.items():
        if files.get_file_from_path(uri) is None:
            files.append(File.generated(config, uri, content=content))
    return files


def main(argv: list[str] | None = None) -> int:
    """``--write``: regenerate the committed copies; ``--check``: exit 1 if one is stale."""
    parser = argparse.ArgumentParser(description="The generated pages of docs/, from the code.")
    parser.add_argument("--write", action="store_true", help="rewrite the stale copies")
    args = parser.parse_args(argv)
    if args.write:
        for uri in write_pages():
            print(f"wrote docs/{uri}")
        return 0
    stale = stale_pages()
    for uri in stale:
        print(f"stale: docs/{uri}")
    return 1 if stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
