"""The page every FMU carries, ``documentation/index.html`` (FMI 2.0 §2.3, FMI 3.0 §2.5).

Written at build time from the FMU's contract table (:mod:`iceimpact.contract`,
:mod:`iceimpact.modal.contract`), so that what a user reads inside the FMU is what the FMU has:
what it is, every variable (name, causality, type, unit, start, allowed range, meaning), how to
run it, its limits (from :mod:`fmu_build.compatibility`) and its licence. The page is
self-contained (no scripts, no links out that it needs, its style inline): it is read from the
unzipped FMU, often offline. Its variables table is laid out by the site's rules
(``docs/stylesheets/variables.css``, copied into its style): names are never broken, the meaning
column wraps, and a table wider than the window scrolls.

:func:`fmu_build.fmi2.build_slave` adds it to the FMI 2.0 FMU; :func:`fmu_build.fmi3.fmi3_from_fmi2`
and :func:`fmu_build.standalone.make_standalone` write it again for what they make, since the
FMI version and what the machine needs differ.
"""

from __future__ import annotations

import html
import importlib
import zipfile
from pathlib import Path
from types import ModuleType

from .layout import MODAL_SLAVE_NAME, ROOT, SLAVE_NAME, VARIABLES_CSS

#: Where the page sits in the FMU.
PAGE = "documentation/index.html"
#: The contract table of each FMU, by its FMI 2.0 model identifier.
CONTRACTS = {SLAVE_NAME: "iceimpact.contract", MODAL_SLAVE_NAME: "iceimpact.modal.contract"}
#: The FMI type names of the contract's kinds.
TYPES = {"2.0": {float: "Real", int: "Integer", bool: "Boolean"},
         "3.0": {float: "Float64", int: "Int32", bool: "Boolean"}}
#: A short paragraph of what each FMU is for, beside the contract's one-line DESCRIPTION.
ABOUT = {
    SLAVE_NAME: (
        "The model of the research article <i>Vibrations due to Flow-Driven Repeated Impacts</i>: "
        "a free ice mass pushed by a current (Morison drag, linearised or quadratic) onto a "
        "flexible structure; impacts conserve momentum with a coefficient of restitution. The "
        "structure is the built-in damped single-degree-of-freedom oscillator, up to five modes, "
        "or another FMU (structure.model = 2, coupled through the coupling.* variables). With the "
        "default solver (solver.method = 1) each communication step is solved exactly: impact "
        "times are located as roots of the gap to machine precision, and the outputs report the "
        "step's impacts and impulse."),
    MODAL_SLAVE_NAME: (
        "The structure FMU that IceImpact.fmu is coupled to in the external-structure mode: a "
        "linear structure given by up to five modes (frequency, damping ratio, modal mass and "
        "mode shape at the contact point), driven by a contact force and giving the contact "
        "point's displacement and velocity back."),
}


def contract_of(model_identifier: str) -> ModuleType:
    """The contract table of the FMU whose FMI 2.0 model identifier is ``model_identifier``."""
    return importlib.import_module(CONTRACTS[model_identifier])


def _cell(text: object) -> str:
    return f"<td>{html.escape(str(text))}</td>"


def variables_table(contract: ModuleType, fmi_version: str) -> str:
    """Every variable of ``contract`` as an HTML table."""
    kinds = TYPES[fmi_version]
    rows = ["<tr><th>name</th><th>causality</th><th>variability</th><th>type</th><th>unit</th>"
            "<th>start</th><th>allowed</th><th>meaning</th></tr>"]
    for v in contract.VARIABLES:
        start = "" if v.start is None else _number(v.start)
        rows.append("<tr>" + f"<td><code>{html.escape(v.name)}</code></td>"
                    + "".join(_cell(x) for x in (v.causality, v.variability, kinds[v.kind],
                                                 v.unit or "–", start, v.allowed,
                                                 v.description)) + "</tr>")
    # the class carries the site's rules (VARIABLES_CSS): names unbroken, the meaning wrapped
    return '<div class="variables">\n<table>\n' + "\n".join(rows) + "\n</table>\n</div>"


def _number(value: float | int | bool) -> str:
    from iceimpact.contract import number_text

    return number_text(value)


def _licence_text() -> str:
    licence = ROOT / "LICENSE"
    return licence.read_text() if licence.exists() else ""


def documentation_page(model_identifier: str, fmi_version: str, standalone: bool) -> str:
    """The HTML page of the FMU ``model_identifier`` (FMI 2.0 name: IceImpact, ModalStructure)
    built for FMI ``fmi_version`` ("2.0" or "3.0"), ``standalone`` if it carries its own Python."""
    # (imported here: ``python -m fmu_build.compatibility`` runs that module as a script)
    from .compatibility import PLATFORM, PYTHONS, STANDALONE_MB

    contract = contract_of(model_identifier)
    name = model_identifier + ("3" if fmi_version == "3.0" else "")
    fmu = f"{name}.fmu"
    title = f"{fmu}: FMI {fmi_version} Co-Simulation, version {contract.VERSION}"
    pythons = ", ".join(PYTHONS[:-1]) + " or " + PYTHONS[-1]
    if standalone:
        needs = ("This is the <b>standalone</b> build: it carries its own Python 3.11 runtime, "
                 "numpy and scipy, so a native host needs no Python on the machine. In a host that "
                 "runs Python itself (FMPy, ecospy) it uses the host's interpreter, and numpy and "
                 "scipy are the host's when it has them; a Python host of another minor version "
                 f"than 3.11 needs numpy and scipy of its own. It is about {STANDALONE_MB} MB.")
    else:
        needs = (f"This is the default build: it needs a Python {pythons} with numpy &gt;= 1.24 "
                 "and scipy &gt;= 1.10 (<code>resources/requirements.txt</code>). In a Python "
                 "host it runs with the host's Python; a native host also needs that Python's "
                 "shared library <code>libpython3.X.so.1.0</code> on the library search path "
                 "(Debian/Ubuntu: <code>apt-get install libpython3.X python3-numpy "
                 "python3-scipy</code>). Where that does not fit, use the standalone build "
                 "(<code>python build_fmu.py --standalone</code>), which brings its own Python.")
    early = ""
    if fmi_version == "3.0" and model_identifier == SLAVE_NAME:
        early = (
            "<p>With <code>early_return_allowed=True</code> (a master that sets "
            "<code>earlyReturnAllowed</code>), a step ends at the first impact in it, or where the "
            "ice leaves the structure it rode on; the next step starts there. It does nothing with "
            "<code>solver.method = 2</code> or <code>coupling.scheme = 2</code> (a Jacobi "
            "master).</p>\n"
            f"<pre>result = simulate_fmu(\"{fmu}\", stop_time=20.0, output_interval=0.01,\n"
            "                      early_return_allowed=True)</pre>\n")
    example_name = "ice.M" if model_identifier == SLAVE_NAME else "modes"
    example_value = "800.0" if model_identifier == SLAVE_NAME else "2"
    default = contract.DEFAULT_EXPERIMENT
    licence = _licence_text()
    licence_html = (f"<pre>{html.escape(licence)}</pre>" if licence else
                    f"<p>{html.escape(contract.LICENSE)}, copyright {contract.AUTHOR}.</p>")
    binaries = "binaries/linux64" if fmi_version == "2.0" else "binaries/x86_64-linux"
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{html.escape(title)}</title>
<style>
body {{ font-family: sans-serif; max-width: 70em; margin: 1em auto; padding: 0 1em; }}
table {{ border-collapse: collapse; font-size: 90%; }}
th, td {{ border: 1px solid #bbb; padding: 0.2em 0.4em; text-align: left; vertical-align: top; }}
pre {{ background: #f4f4f4; padding: 0.5em; overflow-x: auto; }}
div.variables {{ overflow-x: auto; }}
{VARIABLES_CSS.read_text().strip()}
</style>
</head>
<body>
<h1>{html.escape(title)}</h1>
<p>{html.escape(contract.DESCRIPTION)}.</p>
<p>{ABOUT[model_identifier]}</p>
<p>Author: {html.escape(contract.AUTHOR)}. Licence: {html.escape(contract.LICENSE)} (below).</p>

<h2>How to run it</h2>
<p>With FMPy (<code>pip install fmpy</code>):</p>
<pre>from fmpy import simulate_fmu

result = simulate_fmu("{fmu}", stop_time=20.0, output_interval=0.001,
                      start_values={{"{example_name}": {example_value}}})
print(result.dtype.names)   # time and the outputs below</pre>
<p>The default experiment runs {_number(default.start_time)} s to \
{_number(default.stop_time)} s at {_number(default.step_size)} s steps. \
A value outside its allowed range is refused with a message that names the variable, its value \
and the range.</p>
{early}
<h2>Limits</h2>
<ul>
<li>{PLATFORM} only (<code>{binaries}</code>). Windows and macOS are not built or tested.</li>
<li>{needs}</li>
<li>Co-Simulation only (no Model Exchange); FMI {fmi_version}.</li>
</ul>

<h2>Variables</h2>
<p>Units are SI, as in <code>modelDescription.xml</code>; Integer and Boolean variables have none \
(–).</p>
{variables_table(contract, fmi_version)}

<h2>Licence</h2>
{licence_html}
</body>
</html>
"""


def add_to_fmu(fmu: Path, model_identifier: str, fmi_version: str, standalone: bool) -> None:
    """Write the page into the FMU ``fmu`` (a zip without one yet)."""
    page = documentation_page(model_identifier, fmi_version, standalone)
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as zf:
        if PAGE in zf.namelist():
            raise ValueError(f"{fmu} has {PAGE} already")
        zf.writestr(PAGE, page)
