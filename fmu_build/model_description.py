"""The FMI 2.0 modelDescription.xml of a slave, completed from its contract table.

PythonFMU writes no units, ranges or initial unknowns, so modelDescription.xml is completed here:
UnitDefinitions, the unit of every Real, min/max, full-precision start values, descriptions,
ModelStructure (Outputs and InitialUnknowns with their dependencies) and the DefaultExperiment.
All of it comes from the contract table (:mod:`iceimpact.contract`,
:mod:`iceimpact.modal.contract`), never from a second table.
"""

from __future__ import annotations

import re
import zipfile
from pathlib import Path
from types import ModuleType
from xml.dom import minidom
from xml.etree import ElementTree as ET

# SI base-unit exponents of the symbols that unit strings are written with ("N.s/m", "kg/m3").
_SYMBOLS = {
    "kg": {"kg": 1},
    "m": {"m": 1},
    "s": {"s": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "Hz": {"s": -1},
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


def complete_model_description(xml: bytes, contract: ModuleType) -> bytes:
    """Add units, ranges, full-precision start values, descriptions, the model structure (outputs
    and initial unknowns with their dependencies) and the default experiment to PythonFMU's XML,
    all read from a contract table module (:mod:`iceimpact.contract`,
    :mod:`iceimpact.modal.contract`: ``BY_NAME``, name -> variable; ``DEFAULT_EXPERIMENT``)."""
    from iceimpact.contract import DEPENDENT, number_text

    root = ET.fromstring(xml)
    used_units: list[str] = []
    outputs: list[int] = []
    model_variables = root.find("ModelVariables")
    for index, var in enumerate(model_variables.findall("ScalarVariable"), start=1):
        name = var.get("name")
        spec = contract.BY_NAME[name]
        if not var.get("description"):
            var.set("description", spec.description)
        type_node = var[0]
        if type_node.tag == "Real":
            if not spec.unit:
                raise ValueError(f"no unit for the Real variable {name!r}")
            type_node.set("unit", spec.unit)
            if spec.unit not in used_units:
                used_units.append(spec.unit)
        if type_node.tag in ("Integer", "Boolean") and var.get("causality") not in (
                "parameter", "calculatedParameter"):
            var.set("variability", "discrete")
        if type_node.get("start") is not None and spec.start is not None:
            # PythonFMU writes 16 significant digits; the start value is the contract's double
            type_node.set("start", number_text(spec.start))
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
    root.insert(list(root).index(root.find("CoSimulation")) + 1, unit_defs)

    experiment = contract.DEFAULT_EXPERIMENT
    for old in root.findall("DefaultExperiment"):
        root.remove(old)
    root.insert(list(root).index(model_variables), ET.Element("DefaultExperiment", {
        "startTime": number_text(experiment.start_time),
        "stopTime": number_text(experiment.stop_time),
        "stepSize": number_text(experiment.step_size)}))

    # ModelStructure: every output with the knowns it depends on, as the contract declares them
    # (within a step: inputs; at initialization: inputs and parameters, FMI 2.0 section 2.2.8).
    variables = model_variables.findall("ScalarVariable")
    inputs = _indices(variables, lambda var: var.get("causality") == "input")
    initial_knowns = _indices(variables, lambda var: var.get("causality") == "input" or (
        var.get("causality") == "parameter" and var.get("initial", "exact") == "exact"))
    structure = root.find("ModelStructure")
    for old in structure.findall("Outputs") + structure.findall("InitialUnknowns"):
        structure.remove(old)
    listed = ET.Element("Outputs")
    initial = ET.Element("InitialUnknowns")
    for index in outputs:
        spec = contract.BY_NAME[variables[index - 1].get("name")]
        _declare_dependencies(ET.SubElement(listed, "Unknown", index=str(index)),
                              spec.depends_on, inputs, _OUTPUT_KINDS, f"{spec.name}: Outputs")
        _declare_dependencies(ET.SubElement(initial, "Unknown", index=str(index)),
                              dict.fromkeys(spec.initial_depends_on, DEPENDENT),
                              initial_knowns, _INITIAL_KINDS, f"{spec.name}: InitialUnknowns")
    structure.insert(0, listed)  # Outputs, (Derivatives,) InitialUnknowns: the schema's order
    structure.append(initial)

    return pretty_xml(root)


# dependenciesKind values FMI 2.0 allows: for Outputs all five, for InitialUnknowns only these two
_OUTPUT_KINDS = ("dependent", "constant", "fixed", "tunable", "discrete")
_INITIAL_KINDS = ("dependent", "constant")


def _indices(variables: list[ET.Element], wanted) -> dict[str, int]:
    """Name -> ScalarVariable index (from 1) of the variables ``wanted(variable)`` accepts."""
    return {var.get("name"): index for index, var in enumerate(variables, start=1)
            if wanted(var)}


def _declare_dependencies(unknown: ET.Element, kinds: dict[str, str], knowns: dict[str, int],
                          allowed_kinds: tuple[str, ...], where: str) -> None:
    """Set ``dependencies`` (indices, smallest first) and ``dependenciesKind`` of a ModelStructure
    ``Unknown`` from ``{known name: kind}``; ``knowns`` are the names it may list."""
    for name, kind in kinds.items():
        if name not in knowns:
            raise ValueError(f"{where}: {name!r} is not a known here ({', '.join(knowns)})")
        if kind not in allowed_kinds:
            raise ValueError(f"{where}: dependenciesKind {kind!r} of {name!r} is not one of "
                             f"{', '.join(allowed_kinds)}")
    pairs = sorted((knowns[name], kind) for name, kind in kinds.items())
    # both, even empty: no dependencies would mean "depends on every known", and FMPy's validator
    # wants both attributes or neither
    unknown.set("dependencies", " ".join(str(index) for index, _ in pairs))
    unknown.set("dependenciesKind", " ".join(kind for _, kind in pairs))


def pretty_xml(root: ET.Element) -> bytes:
    """``root`` as UTF-8 XML, indented by two spaces, with no blank lines, ending in a newline
    (the form of every modelDescription.xml the build writes)."""
    text = ET.tostring(root, encoding="unicode")
    pretty = minidom.parseString(text).toprettyxml(indent="  ", encoding="UTF-8")
    return b"\n".join(line for line in pretty.splitlines() if line.strip()) + b"\n"


def rewrite_model_description(fmu: Path, contract: ModuleType) -> None:
    """Replace the modelDescription.xml of the FMU file ``fmu`` by
    :func:`complete_model_description` of it; every other entry is kept as it is."""
    with zipfile.ZipFile(fmu) as src:
        entries = [(info, src.read(info)) for info in src.infolist()]
    tmp = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for info, data in entries:
            if info.filename == "modelDescription.xml":
                data = complete_model_description(data, contract)
            dst.writestr(info.filename, data, compress_type=zipfile.ZIP_DEFLATED)
    tmp.replace(fmu)

