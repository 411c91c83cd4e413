"""Build dist/IceImpact.fmu (FMI 2.0 Co-Simulation) with PythonFMU.

    python build_fmu.py [--dest dist]

The FMU carries the slave (fmu_src/IceImpact.py), the model core (the ``iceimpact`` package) and
a requirements.txt (numpy, scipy) under ``resources/``; it runs wherever a Python with numpy and
scipy is available, without ``iceimpact`` being installed.

PythonFMU writes no units, ranges or initial unknowns, so modelDescription.xml is completed here:
UnitDefinitions, the unit of every Real, min/max, ModelStructure/InitialUnknowns and the
DefaultExperiment. Units, descriptions, ranges and the default experiment come from the contract
table ``iceimpact.contract``, never from a second table.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.dom import minidom
from xml.etree import ElementTree as ET

ROOT = Path(__file__).resolve().parent
FMU_SRC = ROOT / "fmu_src"
SLAVE_NAME = "IceImpact"
PACKAGE_NAME = "iceimpact"

# SI base-unit exponents of the symbols that unit strings are written with ("N.s/m", "kg/m3").
_SYMBOLS = {
    "kg": {"kg": 1},
    "m": {"m": 1},
    "s": {"s": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
}


def base_units(unit: str) -> dict[str, int]:
    """SI base-unit exponents of a unit string such as ``"N.s/m"``, ``"kg/m3"`` or ``"1"``."""
    exponents: dict[str, int] = {}
    if unit == "1":
        return exponents
    numerator, _, denominator = unit.partition("/")
    for part, sign in ((numerator, 1), (denominator, -1)):
        for factor in filter(None, part.split(".")):
            match = re.fullmatch(r"([A-Za-z]+)(-?\d*)", factor)
            if match is None or match.group(1) not in _SYMBOLS:
                raise ValueError(f"cannot decompose unit {unit!r} (factor {factor!r})")
            power = int(match.group(2) or 1) * sign
            for base, exp in _SYMBOLS[match.group(1)].items():
                exponents[base] = exponents.get(base, 0) + power * exp
    return {base: exp for base, exp in exponents.items() if exp != 0}


def requirements() -> str:
    """The run-time requirements of the FMU: the project's own dependencies (numpy, scipy)."""
    import tomllib

    with open(ROOT / "pyproject.toml", "rb") as fh:
        deps = tomllib.load(fh)["project"]["dependencies"]
    return "".join(f"{dep}\n" for dep in deps)


def complete_model_description(xml: bytes) -> bytes:
    """Add units, ranges, initial unknowns and the default experiment to PythonFMU's XML."""
    from iceimpact.contract import BY_NAME, DEFAULT_EXPERIMENT, number_text

    root = ET.fromstring(xml)

    used_units: list[str] = []
    outputs: list[int] = []
    model_variables = root.find("ModelVariables")
    for index, var in enumerate(model_variables.findall("ScalarVariable"), start=1):
        name = var.get("name")
        spec = BY_NAME[name]
        if not var.get("description"):
            var.set("description", spec.description)
        type_node = var[0]
        if type_node.tag == "Real":
            unit = spec.unit
            if not unit:
                raise ValueError(f"no unit for the Real variable {name!r}")
            type_node.set("unit", unit)
            if unit not in used_units:
                used_units.append(unit)
        if type_node.tag in ("Integer", "Boolean") and var.get("causality") not in (
                "parameter", "calculatedParameter"):
            var.set("variability", "discrete")
        if type_node.tag in ("Real", "Integer"):
            if spec.minimum is not None:
                type_node.set("min", number_text(spec.minimum))
            if spec.maximum is not None:
                type_node.set("max", number_text(spec.maximum))
        if var.get("causality") == "output":
            outputs.append(index)
            if var.get("initial") is None:
                var.set("initial", "calculated")

    # UnitDefinitions: after <CoSimulation>, before <LogCategories> (fmiModelDescription schema).
    for old in root.findall("UnitDefinitions"):
        root.remove(old)
    unit_defs = ET.Element("UnitDefinitions")
    for unit in sorted(used_units):
        node = ET.SubElement(unit_defs, "Unit", name=unit)
        ET.SubElement(node, "BaseUnit", {k: str(v) for k, v in base_units(unit).items()})
    children = list(root)
    position = children.index(root.find("CoSimulation")) + 1
    root.insert(position, unit_defs)

    for old in root.findall("DefaultExperiment"):
        root.remove(old)
    experiment = ET.Element("DefaultExperiment", {
        "startTime": number_text(DEFAULT_EXPERIMENT.start_time),
        "stopTime": number_text(DEFAULT_EXPERIMENT.stop_time),
        "stepSize": number_text(DEFAULT_EXPERIMENT.step_size)})
    root.insert(list(root).index(model_variables), experiment)

    structure = root.find("ModelStructure")
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    initial = ET.SubElement(structure, "InitialUnknowns")
    for index in outputs:
        # No "dependencies" attribute: an output may depend on every parameter and the input.
        ET.SubElement(initial, "Unknown", index=str(index))

    text = ET.tostring(root, encoding="unicode")
    pretty = minidom.parseString(text).toprettyxml(indent="  ", encoding="UTF-8")
    return b"\n".join(line for line in pretty.splitlines() if line.strip()) + b"\n"


def _rewrite_model_description(fmu: Path) -> None:
    with zipfile.ZipFile(fmu) as src:
        entries = [(info, src.read(info)) for info in src.infolist()]
    tmp = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for info, data in entries:
            if info.filename == "modelDescription.xml":
                data = complete_model_description(data)
            dst.writestr(info.filename, data, compress_type=zipfile.ZIP_DEFLATED)
    tmp.replace(fmu)


def build(dest: str | Path = ROOT / "dist", source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/IceImpact.fmu`` from ``<source_dir>/IceImpact.py`` and its package."""
    source_dir = Path(source_dir).resolve()
    dest = Path(dest).resolve()
    dest.mkdir(parents=True, exist_ok=True)
    if str(source_dir) not in sys.path:
        sys.path.insert(0, str(source_dir))
    from pythonfmu import FmuBuilder

    with tempfile.TemporaryDirectory(prefix="iceimpact_fmu_") as tmp:
        req = Path(tmp) / "requirements.txt"
        req.write_text(requirements())
        fmu = FmuBuilder.build_FMU(
            source_dir / f"{SLAVE_NAME}.py",
            dest=dest,
            project_files=[source_dir / PACKAGE_NAME, req],
            canGetAndSetFMUstate=True,
            canSerializeFMUstate=True,
        )
    fmu = Path(fmu)
    _rewrite_model_description(fmu)
    return fmu


def variables_table(fmu: str | Path) -> str:
    """The variables of a built FMU as the Markdown table of docs/fmu.md (the contract's)."""
    from fmpy import read_model_description

    from iceimpact.contract import markdown_table

    names = [v.name for v in read_model_description(str(fmu)).modelVariables]
    table = markdown_table()
    missing = [n for n in names if f"| `{n}` |" not in table]
    if missing:
        raise ValueError(f"variables of the FMU missing from the contract: {missing}")
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dest", default=str(ROOT / "dist"),
                        help="output folder (default: dist)")
    parser.add_argument("--variables-table", action="store_true",
                        help="also print the variables as a Markdown table (docs/fmu.md)")
    args = parser.parse_args(argv)
    fmu = build(args.dest)
    if args.variables_table:
        print(variables_table(fmu))
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(fmu))
    for problem in problems:
        print(f"validation: {problem}", file=sys.stderr)
    print(f"built {fmu}" + ("" if not problems else f" ({len(problems)} validation problems)"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
