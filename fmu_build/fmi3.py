"""FMI 3.0 Co-Simulation FMUs made of FMI 2.0 ones: IceImpact3.fmu and ModalStructure3.fmu.

Each is made from the FMI 2.0 FMU itself (:func:`fmi3_from_fmi2`: the same slave, model core and
resources, byte for byte), and a standalone one from the standalone FMI 2.0 FMU::

    modelDescription.xml                      FMI 3.0, converted from the FMI 2.0 one
                                              (fmi3_model_description: the same variables,
                                              value references, units, ranges, start values,
                                              descriptions, dependencies, default experiment)
    binaries/x86_64-linux/<id>3.so            fmu_native/fmi3.c, compiled here (it includes
                                              the FMI 2.0 loader, loader.c)
    binaries/x86_64-linux/pythonfmu/<id>.so   PythonFMU's FMI 2.0 library, as in the FMI 2.0 FMU
    binaries/x86_64-linux/python/             the standalone runtime (standalone FMUs only)
    resources/                                as in the FMI 2.0 FMU
"""

from __future__ import annotations

import json
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from .documentation import PAGE, documentation_page
from .fmi2 import build, build_modal
from .layout import DIST, MODAL_SLAVE_NAME, SLAVE_NAME
from .model_description import pretty_xml
from .native import (
    FMI3_SOURCE,
    NATIVE_PLATFORM,
    NativeBuildError,
    builds_native_loader,
    compile_loader,
    libpython,
)
from .standalone import STANDALONE_DIR, make_standalone

FMI3_PLATFORM = "x86_64-linux"
#: The FMI 3.0 FMUs: the FMI 2.0 model identifier -> (the FMI 3.0 one, whether its steps may
#: return early, at contact events).
FMI3_MODELS = {SLAVE_NAME: ("IceImpact3", True), MODAL_SLAVE_NAME: ("ModalStructure3", False)}
#: FMI 2.0 ModelStructure lists -> FMI 3.0 elements.
_FMI3_STRUCTURE = {"Outputs": "Output", "Derivatives": "ContinuousStateDerivative",
                   "InitialUnknowns": "InitialUnknown"}
_FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def fmi3_model_description(xml: bytes, model_name: str, model_identifier: str,
                           returns_early: bool, time_reference: int,
                           standalone: bool = False) -> bytes:
    """The FMI 3.0 modelDescription.xml of an FMI 2.0 one completed by
    :func:`fmu_build.model_description.complete_model_description` (so: of the contract table):
    the same model and variables, the FMI 3.0 types and attributes, dependencies by value
    reference, and the independent variable FMI 3.0 asks for, ``time``, with value reference
    ``time_reference`` (the slave's REACHED_TIME: fmi3GetFloat64 of it gives the instance's
    time)."""
    src = ET.fromstring(xml)
    attrs = {key: src.get(key) for key in (
        "description", "author", "version", "license", "generationTool",
        "generationDateAndTime", "variableNamingConvention") if src.get(key) is not None}
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": model_name,
        "instantiationToken": "{" + src.get("guid").strip("{}") + "}", **attrs})
    cs = src.find("CoSimulation")
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": model_identifier,
        "needsExecutionTool": "false" if standalone else cs.get("needsExecutionTool", "true"),
        "canHandleVariableCommunicationStepSize": "true",
        "canBeInstantiatedOnlyOncePerProcess": cs.get("canBeInstantiatedOnlyOncePerProcess",
                                                      "false"),
        "canGetAndSetFMUState": cs.get("canGetAndSetFMUstate", "false"),
        "canSerializeFMUState": cs.get("canSerializeFMUstate", "false"),
        "hasEventMode": "true",
        "mightReturnEarlyFromDoStep": "true" if returns_early else "false",
        "canReturnEarlyAfterIntermediateUpdate": "false",
        "providesIntermediateUpdate": "false"})
    for tag in ("UnitDefinitions", "LogCategories", "DefaultExperiment"):
        node = src.find(tag)
        if node is not None:
            root.append(node)
    units = root.find("UnitDefinitions")
    if units is None:
        units = ET.Element("UnitDefinitions")
        root.insert(list(root).index(root.find("CoSimulation")) + 1, units)
    if not any(unit.get("name") == "s" for unit in units):  # the unit of time
        ET.SubElement(ET.SubElement(units, "Unit", name="s"), "BaseUnit", s="1")
        units[:] = sorted(units, key=lambda unit: unit.get("name"))
    for category in root.iterfind("LogCategories/Category"):
        category.set("description", category.get("description", "").replace("fmi2", "fmi3"))
    variables = ET.SubElement(root, "ModelVariables")
    ET.SubElement(variables, "Float64", name="time", valueReference=str(time_reference),
                  description="simulation time", causality="independent",
                  variability="continuous", unit="s")
    references = []
    for scalar in src.find("ModelVariables").findall("ScalarVariable"):
        typed = scalar[0]
        node = ET.SubElement(variables, _FMI3_TYPES[typed.tag], {
            key: scalar.get(key) for key in ("name", "valueReference", "description",
                                             "causality", "variability", "initial")
            if scalar.get(key) is not None})
        references.append(scalar.get("valueReference"))
        for key in ("unit", "min", "max", "nominal"):
            if typed.get(key) is not None:
                node.set(key, typed.get(key))
        if typed.get("start") is not None:
            if typed.tag == "String":
                ET.SubElement(node, "Start", value=typed.get("start"))
            else:
                node.set("start", typed.get("start"))
    structure = ET.SubElement(root, "ModelStructure")
    for tag in ("Outputs", "Derivatives", "InitialUnknowns"):
        for unknown in src.find("ModelStructure").iterfind(f"{tag}/Unknown"):
            item = ET.SubElement(structure, _FMI3_STRUCTURE[tag], valueReference=references[
                int(unknown.get("index")) - 1])
            if unknown.get("dependencies") is not None:
                item.set("dependencies", " ".join(
                    references[int(i) - 1] for i in unknown.get("dependencies").split()))
                item.set("dependenciesKind", unknown.get("dependenciesKind", ""))
    return pretty_xml(root)


def fmi3_from_fmi2(fmu: Path, dest: str | Path, bundled_python: bool = False) -> Path:
    """Write ``<dest>/<id>3.fmu``, the FMI 3.0 FMU made of ``fmu``, the FMI 2.0 FMU ``<id>.fmu``
    (a build of :func:`fmu_build.fmi2.build_slave`, or with ``bundled_python`` of
    :func:`fmu_build.standalone.make_standalone`)."""
    from iceimpact.fmi.lifecycle import EARLY_RETURN, REACHED_TIME
    from iceimpact.fmi.slave_base import FMI3_CHANNEL

    with zipfile.ZipFile(fmu) as src:
        entries = {info.filename: src.read(info) for info in src.infolist()}
    model = ET.fromstring(entries["modelDescription.xml"]).find("CoSimulation").get(
        "modelIdentifier")
    identifier, returns_early = FMI3_MODELS[model]
    old, new = f"binaries/{NATIVE_PLATFORM}/", f"binaries/{FMI3_PLATFORM}/"
    out: dict[str, bytes] = {}
    for name, data in entries.items():
        if name.startswith("binaries/") and not name.startswith(old):
            continue  # (PythonFMU's Windows library: FMI 2.0 only)
        if name == f"{old}{model}.so":
            continue  # the FMI 2.0 loader: compiled into the FMI 3.0 library below
        if name == "modelDescription.xml":
            data = fmi3_model_description(data, model, identifier, returns_early,
                                          FMI3_CHANNEL[REACHED_TIME][0],
                                          standalone=bundled_python)
        elif name == "resources/iceimpact_fmu/python.json":
            config = json.loads(data.replace(old.encode(), new.encode()))
            config["model_identifier"] = identifier  # (the boot module's messages name it)
            data = (json.dumps(config, indent=2) + "\n").encode()
        out[new + name[len(old):] if name.startswith(old) else name] = data
    # the page of the FMI 2.0 FMU names FMI 2.0's types and binaries: written anew
    out[PAGE] = documentation_page(model, "3.0", standalone=bundled_python).encode()
    with tempfile.TemporaryDirectory(prefix="iceimpact_fmi3_") as tmp:
        library = Path(tmp) / f"{identifier}.so"
        options = dict(source=FMI3_SOURCE, model_identifier=identifier,
                       extra_defines={"EARLY_RETURN_VR": FMI3_CHANNEL[EARLY_RETURN][0],
                                      "REACHED_TIME_VR": FMI3_CHANNEL[REACHED_TIME][0]})
        if bundled_python:
            compile_loader(library, None, config["standalone"]["libpython"],
                           f"pythonfmu/{model}.so", bundled_python=True, **options)
        else:
            path, soname = libpython()
            compile_loader(library, path, soname, f"pythonfmu/{model}.so", **options)
        out[f"{new}{identifier}.so"] = library.read_bytes()
    target = Path(dest).resolve() / f"{identifier}.fmu"
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_fmu = target.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED,
                         compresslevel=9 if bundled_python else None) as dst:
        for name in sorted(out):
            dst.writestr(name, out[name])
    tmp_fmu.replace(target)
    return target


def build_fmi3(model: str = SLAVE_NAME, dest: str | Path = DIST,
               standalone_dest: str | Path | None = None, fmu: Path | None = None,
               standalone: Path | None = None) -> Path:
    """Build ``<dest>/<model>3.fmu`` (FMI 3.0; ``model``: IceImpact or ModalStructure) from the
    FMI 2.0 FMU ``fmu`` (default: built here), and with ``standalone_dest`` its standalone
    variant there, from the standalone FMI 2.0 FMU ``standalone`` (default: made here)."""
    if not builds_native_loader():
        raise NativeBuildError("the FMI 3.0 FMUs are built on Linux x86_64 only")
    with tempfile.TemporaryDirectory(prefix="iceimpact_fmi2_of_3_") as tmp:
        if fmu is None:
            fmu = (build if model == SLAVE_NAME else build_modal)(tmp)
        target = fmi3_from_fmi2(fmu, dest)
        if standalone_dest is not None:
            if standalone is None:
                standalone = make_standalone(fmu, Path(tmp) / STANDALONE_DIR, model)
            fmi3_from_fmi2(standalone, standalone_dest, bundled_python=True)
    return target

