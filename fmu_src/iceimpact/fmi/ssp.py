"""IceOnStructure.ssp: the system file of IceImpact.fmu (structure.model = 2) coupled to
ModalStructure.fmu, one file that FMPy, ECOS, libcosim and OMSimulator load as it is.

The system (components ``floe`` and ``structure``)::

    floe.coupling.force -> structure.force
    structure.x         -> floe.structure.x_in
    structure.v         -> floe.structure.v_in
    structure.a         -> floe.structure.a_in

The SSP (:func:`write_ssp`) carries ``SystemStructure.ssd`` (parameters bound inline,
OpenModelica's fixed-step master, a DefaultExperiment of 2 s with the OSP step of 1 ms), both FMUs
and the same parameters as ``resources/IceOnStructure.ssv`` under ``resources/``;
docs/how-to/couple-to-a-structure.md ("The system file in five masters") says which master
needs which part. Every master that loads it is a Jacobi scheme, so it binds
``coupling.scheme = 2``. The build writes it beside the FMUs (``python build_fmu.py``);
examples/system/system.py runs it in every master.
"""

from __future__ import annotations

import zipfile
from collections import defaultdict
from pathlib import Path
from xml.etree import ElementTree

#: The scene: an impacting floe (tests/system/test_coupling.py's first scene).
ICE = {"structure.model": 2, "drag.model": 2, "ice.M": 1200.0, "impact.e": 0.7,
       "structure.m": 1600.0}
#: IceImpact's coupling.scheme for each master's scheme
SCHEMES = {"gauss-seidel": 1, "jacobi": 2}
#: The flow speed, m/s.
FLOW_U = 0.3
#: ModalStructure's default is one mode equal to IceImpact's built-in structure.
STRUCTURE: dict[str, float] = {}
#: The Integer variables of both FMUs
INTEGERS = {"structure.model", "coupling.scheme", "drag.model", "solver.method",
            "solver.detection", "solver.ode_method", "solver.max_impacts", "contact.count",
            "modes"}
#: The experiment the SSP carries: 2 s at 1 ms communication steps.
T_END, STEP = 2.0, 1e-3

#: The connections, between the roles ``ice`` (IceImpact.fmu) and ``structure``
#: (ModalStructure.fmu).
CONNECTIONS = [("ice", "coupling.force", "structure", "force"),
               ("structure", "x", "ice", "structure.x_in"),
               ("structure", "v", "ice", "structure.v_in"),
               ("structure", "a", "ice", "structure.a_in")]
#: The component of each role in the SSP and the masters. IceImpact's is not named ``ice``:
#: OMSimulator strips a component's name from the front of the names bound to it (``ice.M`` on
#: ``ice`` becomes ``M``, unknown: the floe keeps its default mass).
ICE_COMPONENT, STRUCTURE_COMPONENT = "floe", "structure"
COMPONENTS = {"ice": ICE_COMPONENT, "structure": STRUCTURE_COMPONENT}
#: The parameter set: inline in the SSD under this name, and as a file in the SSP for FMPy.
PARAMETER_SET, SSV = "initialValues", "resources/IceOnStructure.ssv"

# The XML namespaces of the SSP's files (SSP 1.0, OMSimulator's and OSP's annotations).
_NAMESPACES = {
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
}


def fmu_variables(fmu: Path) -> dict[str, tuple[str, str]]:
    """name -> (FMI type, causality) of an FMU's variables, from its modelDescription.xml."""
    with zipfile.ZipFile(fmu) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    return {v.get("name"): (next(iter(v)).tag, v.get("causality", "local"))
            for v in root.iter("ScalarVariable")}


def bindings(ice: dict = ICE, structure: dict = STRUCTURE, flow_u: float = FLOW_U) -> dict:
    """The values the SSP binds, by component: IceImpact's with coupling.scheme = 2 (every
    master that reads the SSP is a Jacobi scheme) and flow.u."""
    return {ICE_COMPONENT: {**ice, "coupling.scheme": SCHEMES["jacobi"], "flow.u": flow_u},
            STRUCTURE_COMPONENT: dict(structure)}


def _value(kind: str, value) -> str:
    """An SSV value as its type writes it (an Integer 2.0 would be refused as "2.0")."""
    if kind == "Integer":
        return str(int(value))
    if kind == "Boolean":
        return "true" if value else "false"
    return repr(float(value))


def _default_types() -> dict[str, tuple[str, str]]:
    """The FMI types when the FMUs are not at hand: INTEGERS, the rest Real."""
    return defaultdict(lambda: ("Real", "parameter"),
                       {name: ("Integer", "parameter") for name in INTEGERS})


def _parameters(values: dict, types: dict[str, tuple[str, str]], indent: str,
                prefix: str = "") -> str:
    """SSV ``Parameter`` elements of ``values``, one a line, each name after ``prefix``."""
    return "\n".join(f'{indent}<ssv:Parameter name="{prefix}{name}"><ssv:{types[name][0]} '
                      f'value="{_value(types[name][0], value)}"/></ssv:Parameter>'
                      for name, value in values.items())


def _component(name: str, fmu: str, inputs: list[str], outputs: list[str], values: dict,
               types: dict[str, tuple[str, str]]) -> str:
    """The SSD ``Component`` ``name`` of ``resources/<fmu>``: its connectors and, if ``values``,
    its parameters bound inline (set ``initialValues``)."""
    connectors = [f'          <ssd:Connector name="{c}" kind="{kind}"><ssc:{types[c][0]}/>'
                  "</ssd:Connector>"
                  for kind, names in (("input", inputs), ("output", outputs)) for c in names]
    binding = ""
    if values:
        binding = ("\n        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>\n"
                   f'          <ssv:ParameterSet version="1.0" name="{PARAMETER_SET}">'
                   "<ssv:Parameters>\n" + _parameters(values, types, " " * 12)
                   + "\n          </ssv:Parameters></ssv:ParameterSet>\n"
                   "        </ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>")
    return (f'      <ssd:Component name="{name}" source="resources/{fmu}" '
            'type="application/x-fmu-sharedlibrary">\n        <ssd:Connectors>\n'
            + "\n".join(connectors) + "\n        </ssd:Connectors>" + binding
            + "\n      </ssd:Component>")


def connections(second_order: bool = True) -> list[tuple[str, str, str, str]]:
    """The connections; without ``a -> structure.a_in`` (first-order extrapolation, IceImpact's
    ``structure.a_in`` stays 0) unless ``second_order``."""
    return CONNECTIONS if second_order else CONNECTIONS[:3]


def _check(values: dict, types: dict[str, tuple[str, str]], component: str) -> None:
    """Refuse what a master would drop silently (libcosim ignores an unknown name, FMPy and
    OMSimulator would fail at a later step)."""
    for name in values:
        if types.get(name, ("", ""))[1] not in ("parameter", "input"):
            raise ValueError(f"{component}: {name!r} is no parameter or input of the FMU")
        if name.split(".")[0] == component:  # OMSimulator strips it: ice.M on ice -> M
            raise ValueError(f"{component}: the component's name begins {name!r}")


def system_structure(ice: dict = ICE, structure: dict = STRUCTURE, flow_u: float = FLOW_U,
                     second_order: bool = True, t_end: float = T_END, h: float = STEP,
                     types: dict[str, dict] | None = None) -> str:
    """SystemStructure.ssd of the coupled system: the parameters bound inline in each component
    (set ``initialValues``), OpenModelica's fixed-step master with the step ``h`` (OMSimulator
    loads no system without it), a DefaultExperiment of ``t_end`` with the OSP step ``h``
    (libcosim's ``from_ssp_file`` takes its step from it). ``types``: component -> the FMU's
    :func:`fmu_variables` (read from the FMUs by :func:`write_ssp`; by default IceImpact's
    integers are those of ``INTEGERS``)."""
    values = bindings(ice, structure, flow_u)
    types = types or {c: _default_types() for c in values}
    ice_io = (["structure.x_in", "structure.v_in", "structure.a_in"],
              ["coupling.force", "contact.force", "contact.count"])
    components = [
        _component(ICE_COMPONENT, "IceImpact.fmu", *ice_io, values[ICE_COMPONENT],
                   types[ICE_COMPONENT]),
        _component(STRUCTURE_COMPONENT, "ModalStructure.fmu", ["force"], ["x", "v", "a"],
                   values[STRUCTURE_COMPONENT], types[STRUCTURE_COMPONENT]),
    ]
    links = [f'      <ssd:Connection startElement="{COMPONENTS[a]}" startConnector="{ca}" '
             f'endElement="{COMPONENTS[b]}" endConnector="{cb}"/>'
             for a, ca, b, cb in connections(second_order)]
    namespaces = "\n".join(f'    xmlns:{k}="{v}"' for k, v in _NAMESPACES.items())
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<ssd:SystemStructureDescription version="1.0" name="IceOnStructure"\n'
            + namespaces + ">\n"
            '  <ssd:System name="IceOnStructure">\n    <ssd:Elements>\n'
            + "\n".join(components) + "\n    </ssd:Elements>\n    <ssd:Connections>\n"
            + "\n".join(links) + "\n    </ssd:Connections>\n"
            # OMSimulator: its weakly coupled system's fixed-step master, in the form it writes
            '    <ssd:Annotations><ssc:Annotation type="org.openmodelica"><oms:Annotations>\n'
            "      <oms:SimulationInformation>"
            f'<oms:FixedStepMaster description="oms-ma" stepSize="{h!r}" '
            'relativeTolerance="0.0001"/></oms:SimulationInformation>\n'
            "    </oms:Annotations></ssc:Annotation></ssd:Annotations>\n"
            "  </ssd:System>\n"
            # libcosim: the algorithm and its step (ssp_parser.cpp reads this form only)
            f'  <ssd:DefaultExperiment startTime="0.0" stopTime="{t_end!r}">\n'
            '    <ssd:Annotations><ssc:Annotation type="com.opensimulationplatform">'
            f'<osp:Algorithm><osp:FixedStepAlgorithm baseStepSize="{h!r}"/></osp:Algorithm>'
            "</ssc:Annotation></ssd:Annotations>\n"
            "  </ssd:DefaultExperiment>\n"
            "</ssd:SystemStructureDescription>\n")


def parameter_values(ice: dict = ICE, structure: dict = STRUCTURE, flow_u: float = FLOW_U,
                     types: dict[str, dict] | None = None) -> str:
    """The same bindings as one SSV parameter set, each name prefixed by its component's (what
    FMPy's ``simulate_ssp(parameter_set=read_ssv(...))`` applies: it ignores inline
    bindings)."""
    values = bindings(ice, structure, flow_u)
    types = types or {c: _default_types() for c in values}
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<ssv:ParameterSet version="1.0" name="{PARAMETER_SET}"\n'
            f'    xmlns:ssc="{_NAMESPACES["ssc"]}"\n    xmlns:ssv="{_NAMESPACES["ssv"]}">\n'
            "  <ssv:Parameters>\n"
            + "\n".join(_parameters(v, types[c], "    ", f"{c}.")
                        for c, v in values.items() if v)
            + "\n  </ssv:Parameters>\n</ssv:ParameterSet>\n")


def write_ssp(fmus: Path, path: Path, ice: dict = ICE, structure: dict = STRUCTURE,
              flow_u: float = FLOW_U, second_order: bool = True, t_end: float = T_END,
              h: float = STEP) -> Path:
    """IceOnStructure.ssp from the folder ``fmus`` holding IceImpact.fmu and ModalStructure.fmu:
    SystemStructure.ssd (:func:`system_structure`), both FMUs and the parameter set
    ``resources/IceOnStructure.ssv`` (:func:`parameter_values`) under ``resources/``. Every
    bound name is checked against the FMU's model description."""
    fmus, path = Path(fmus), Path(path)
    sources = {ICE_COMPONENT: fmus / "IceImpact.fmu",
               STRUCTURE_COMPONENT: fmus / "ModalStructure.fmu"}
    types = {c: fmu_variables(fmu) for c, fmu in sources.items()}
    for component, values in bindings(ice, structure, flow_u).items():
        _check(values, types[component], component)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd",
                   system_structure(ice, structure, flow_u, second_order, t_end, h, types))
        z.writestr(SSV, parameter_values(ice, structure, flow_u, types))
        for fmu in sources.values():
            z.write(fmu, f"resources/{fmu.name}")
    return path


def experiment(ssp: Path) -> tuple[float, float, float]:
    """(start, stop, step) of the SSP: its DefaultExperiment and the OSP step libcosim reads."""
    with zipfile.ZipFile(ssp) as z:
        root = ElementTree.fromstring(z.read("SystemStructure.ssd"))
    default = root.find("ssd:DefaultExperiment", _NAMESPACES)
    step = default.find(".//osp:FixedStepAlgorithm", _NAMESPACES)
    return (float(default.get("startTime", 0.0)), float(default.get("stopTime")),
            float(step.get("baseStepSize")))

