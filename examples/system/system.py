"""An ice floe striking a structure from another FMU: IceImpact.fmu (structure.model = 2) coupled
to ModalStructure.fmu, by three masters, on one system.

The system (``IceOnStructure.ssp``: ``SystemStructure.ssd`` and both FMUs under ``resources/``)::

    ice.coupling.force -> structure.force
    structure.x       -> ice.structure.x_in
    structure.v       -> ice.structure.v_in
    structure.a       -> ice.structure.a_in

The masters (fixed communication step h), each with IceImpact's ``coupling.scheme`` set to its
scheme:

- ``fmpy_master(..., scheme="gauss-seidel")``: a scripted loop over FMPy's ``FMU2Slave``, ice
  first: the ice steps against the structure's state at the step start, then the structure steps
  with the ice's force of that same step (the scheme of tests/coupling_master.py;
  ``coupling.scheme = 1``);
- ``fmpy_master(..., scheme="jacobi")``: both step from the values of the previous step end, then
  the outputs are passed on (the structure's force is one step older; ``coupling.scheme = 2``);
- ``ecospy_run``: the SSP run by ECOS (ecospy), whose fixed-step algorithm is the Jacobi scheme:
  it equals the FMPy Jacobi master to rounding (the SSP binds ``coupling.scheme = 2``);
- ``libcosimpy_run``: the same system in libcosim (libcosimpy), also a Jacobi scheme.

Run ``python examples/system/system.py --fmus dist`` after ``python build_fmu.py``: it writes the
SSP, runs every master, prints how far each is from IceImpact's own monolithic run (the built-in
structure, structure.model = 1, equal to the default mode of ModalStructure.fmu) and the
agreement of the masters.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import zipfile
from pathlib import Path

import numpy as np

#: The scene: an impacting floe (tests/test_coupling.py's first scene).
ICE = {"structure.model": 2, "drag.model": 2, "ice.M": 1200.0, "impact.e": 0.7,
       "structure.m": 1600.0}
#: IceImpact's coupling.scheme for each master's scheme
SCHEMES = {"gauss-seidel": 1, "jacobi": 2}
FLOW_U = 0.3
#: ModalStructure's default is one mode equal to IceImpact's built-in structure.
STRUCTURE: dict[str, float] = {}
INTEGERS = {"structure.model", "coupling.scheme", "drag.model", "solver.method", "modes"}

CONNECTIONS = [("ice", "coupling.force", "structure", "force"),
               ("structure", "x", "ice", "structure.x_in"),
               ("structure", "v", "ice", "structure.v_in"),
               ("structure", "a", "ice", "structure.a_in")]


# The SSP ------------------------------------------------------------------------------------------
def _parameter(name: str, value) -> str:
    kind = "Integer" if name in INTEGERS else "Real"
    return (f'            <ssv:Parameter name="{name}"><ssv:{kind} value="{value!r}"/>'
            f'</ssv:Parameter>')


def _component(name: str, fmu: str, inputs: list[str], outputs: list[str],
               parameters: dict) -> str:
    connectors = [f'        <ssd:Connector name="{c}" kind="input"><ssc:Real/></ssd:Connector>'
                  for c in inputs]
    connectors += [f'        <ssd:Connector name="{c}" kind="output"><ssc:Real/></ssd:Connector>'
                   for c in outputs]
    bindings = ""
    if parameters:
        bindings = ("\n      <ssd:ParameterBindings><ssd:ParameterBinding>"
                    "<ssd:ParameterValues>\n"
                    '        <ssv:ParameterSet version="1.0" name="initialValues">'
                    "<ssv:Parameters>\n"
                    + "\n".join(_parameter(k, v) for k, v in parameters.items())
                    + "\n        </ssv:Parameters></ssv:ParameterSet>\n"
                    "      </ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>")
    return (f'    <ssd:Component name="{name}" source="resources/{fmu}" '
            'type="application/x-fmu-sharedlibrary">\n      <ssd:Connectors>\n'
            + "\n".join(connectors) + "\n      </ssd:Connectors>" + bindings
            + "\n    </ssd:Component>")


def connections(second_order: bool = True) -> list[tuple[str, str, str, str]]:
    """The connections; without ``a -> structure.a_in`` (first-order extrapolation, IceImpact's
    ``structure.a_in`` stays 0) unless ``second_order``."""
    return CONNECTIONS if second_order else CONNECTIONS[:3]


def system_structure(ice: dict, structure: dict, flow_u: float,
                     second_order: bool = True) -> str:
    """SystemStructure.ssd of the coupled system (parameters bound in the file)."""
    components = [
        _component("ice", "IceImpact.fmu",
                   ["structure.x_in", "structure.v_in", "structure.a_in"],
                   ["coupling.force", "contact.force"],
                   {**ice, "coupling.scheme": SCHEMES["jacobi"], "flow.u": flow_u}),
        _component("structure", "ModalStructure.fmu", ["force"], ["x", "v", "a"], structure),
    ]
    links = [f'      <ssd:Connection startElement="{a}" startConnector="{ca}" '
             f'endElement="{b}" endConnector="{cb}"/>'
             for a, ca, b, cb in connections(second_order)]
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<ssd:SystemStructureDescription version="1.0" name="IceOnStructure"\n'
            '    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"\n'
            '    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"\n'
            '    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">\n'
            '  <ssd:System name="IceOnStructure">\n    <ssd:Elements>\n'
            + "\n".join(components) + "\n    </ssd:Elements>\n    <ssd:Connections>\n"
            + "\n".join(links) + "\n    </ssd:Connections>\n  </ssd:System>\n"
            "</ssd:SystemStructureDescription>\n")


def write_ssp(fmus: Path, path: Path, ice: dict = ICE, structure: dict = STRUCTURE,
              flow_u: float = FLOW_U, second_order: bool = True) -> Path:
    """IceOnStructure.ssp: SystemStructure.ssd and the two FMUs from the folder ``fmus``."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd",
                   system_structure(ice, structure, flow_u, second_order))
        for name in ("IceImpact.fmu", "ModalStructure.fmu"):
            z.write(fmus / name, f"resources/{name}")
    return path


# FMPy ---------------------------------------------------------------------------------------------
class Slave:
    """One FMU2Slave stepped by hand (FMPy's default logger)."""

    def __init__(self, fmu: Path, name: str, values: dict):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.dir = extract(str(fmu))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self.dir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        for key, value in values.items():
            self.set(key, value)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def set(self, name: str, value) -> None:
        if name in INTEGERS:
            self.fmu.setInteger([self.vr[name]], [int(value)])
        else:
            self.fmu.setReal([self.vr[name]], [float(value)])

    def get(self, name: str) -> float:
        return self.fmu.getReal([self.vr[name]])[0]

    def get_integer(self, name: str) -> int:
        return self.fmu.getInteger([self.vr[name]])[0]

    def step(self, t: float, h: float) -> None:
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def fmpy_master(fmus: Path, t_end: float, h: float, scheme: str = "gauss-seidel",
                ice: dict = ICE, structure: dict = STRUCTURE, flow_u: float = FLOW_U,
                second_order: bool = True) -> dict[str, np.ndarray]:
    """The coupled run through FMPy: time, the structure's x, the ice's contact.force and
    contact.count at the communication points (index k: time k h); ``count``: the last one."""
    ice_fmu = Slave(fmus / "IceImpact.fmu", "ice",
                    {**ice, "coupling.scheme": SCHEMES[scheme], "flow.u": flow_u})
    st = Slave(fmus / "ModalStructure.fmu", "structure", structure)
    n = round(t_end / h)
    t, x, force, counts = np.arange(n + 1) * h, [st.get("x")], [0.0], [0]
    try:
        for k in range(n):
            # the ice gets the structure at the step start (both schemes)
            for _, source, _, sink in connections(second_order)[1:]:
                ice_fmu.set(sink, st.get(source))
            if scheme == "jacobi":  # the force of the previous step end
                st.set("force", ice_fmu.get("coupling.force"))
                ice_fmu.step(k * h, h)
            else:                   # ice first, its force of this same step
                ice_fmu.step(k * h, h)
                st.set("force", ice_fmu.get("coupling.force"))
            st.step(k * h, h)
            x.append(st.get("x"))
            force.append(ice_fmu.get("contact.force"))
            counts.append(ice_fmu.get_integer("contact.count"))
    finally:
        ice_fmu.close()
        st.close()
    return {"time": t, "x": np.array(x), "force": np.array(force), "counts": np.array(counts),
            "count": counts[-1]}


def monolithic(fmus: Path, t_end: float, h: float, ice: dict = ICE,
               flow_u: float = FLOW_U) -> dict[str, np.ndarray]:
    """IceImpact.fmu alone with its built-in structure (structure.model = 1)."""
    from fmpy import simulate_fmu

    values = {**ice, "structure.model": 1, "flow.u": flow_u}
    values.pop("coupling.scheme", None)
    result = simulate_fmu(str(fmus / "IceImpact.fmu"), start_time=0.0, stop_time=t_end,
                          output_interval=h, start_values=values,
                          output=["structure.x", "contact.force", "contact.count"])
    return {"time": result["time"], "x": result["structure.x"], "force": result["contact.force"],
            "counts": result["contact.count"], "count": int(result["contact.count"][-1])}


# ecospy and libcosimpy ----------------------------------------------------------------------------
def ecospy_run(ssp: Path, t_end: float, h: float) -> dict[str, np.ndarray]:
    """The SSP through ECOS (its Jacobi fixed-step algorithm)."""
    import ecospy

    rows: list[tuple[float, float, float]] = []

    class Recorder(ecospy.SimulationListener):
        def post(self, info):
            rows.append((sim.get_time(), sim.get_real("structure::x"),
                         sim.get_real("ice::contact.force")))

    with ecospy.EcosSimulation(ssp_path=str(ssp), step_size=h) as sim:
        sim.add_listener("recorder", Recorder())
        sim.init(parameter_set="initialValues")
        first = (0.0, sim.get_real("structure::x"), sim.get_real("ice::contact.force"))
        sim.step(round(t_end / h))
        count = sim.get_integer("ice::contact.count")
        sim.terminate()
    data = np.array([first] + rows)
    return {"time": data[:, 0], "x": data[:, 1], "force": data[:, 2], "count": count}


def libcosimpy_run(fmus: Path, t_end: float, h: float, ice: dict = ICE,
                   structure: dict = STRUCTURE, flow_u: float = FLOW_U,
                   second_order: bool = True) -> dict[str, np.ndarray]:
    """The same system in libcosim (fixed-step algorithm, Jacobi), built by hand."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    nanos = round(h * 1e9)
    execution = CosimExecution.from_step_size(step_size=nanos)
    slaves = {name: execution.add_local_slave(CosimLocalSlave(str(fmus / fmu), name))
              for name, fmu in (("ice", "IceImpact.fmu"), ("structure", "ModalStructure.fmu"))}
    refs = {}
    for name, index in slaves.items():
        refs[name] = {v.name.decode(): v.reference
                      for v in execution.slave_variables(index)}
    ice = {**ice, "coupling.scheme": SCHEMES["jacobi"], "flow.u": flow_u}
    for name, values in (("ice", ice), ("structure", structure)):
        for key, value in values.items():
            if key in INTEGERS:
                execution.integer_initial_value(slaves[name], refs[name][key], int(value))
            else:
                execution.real_initial_value(slaves[name], refs[name][key], float(value))
    for a, ca, b, cb in connections(second_order):
        execution.connect_real_variables(slaves[a], refs[a][ca], slaves[b], refs[b][cb])
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    n = round(t_end / h)
    rows = []
    for _ in range(n):
        execution.step()
        rows.append((observer.last_real_values(slaves["structure"], [refs["structure"]["x"]])[0],
                     observer.last_real_values(slaves["ice"], [refs["ice"]["contact.force"]])[0]))
    x = [0.0] + [r[0] for r in rows]
    force = [0.0] + [r[1] for r in rows]
    t = np.arange(n + 1) * h
    count = observer.last_integer_values(slaves["ice"], [refs["ice"]["contact.count"]])[0]
    return {"time": t, "x": np.array(x), "force": np.array(force), "count": count}


def relative_error(run: dict, reference: dict) -> float:
    """max |x - x_ref| / max |x_ref| over the common communication points."""
    n = min(len(run["x"]), len(reference["x"]))
    return float(np.max(np.abs(run["x"][:n] - reference["x"][:n]))
                 / np.max(np.abs(reference["x"][:n])))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmus", type=Path, default=Path("dist"),
                        help="folder with IceImpact.fmu and ModalStructure.fmu (default: dist)")
    parser.add_argument("--ssp", type=Path, default=None,
                        help="where to write IceOnStructure.ssp (default: a temporary folder)")
    parser.add_argument("--t-end", type=float, default=6.0)
    parser.add_argument("--step", type=float, default=1e-3)
    parser.add_argument("--no-libcosim", action="store_true")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ssp = write_ssp(args.fmus, args.ssp or Path(tmp) / "IceOnStructure.ssp")
        print(f"wrote {ssp}")
        mono = monolithic(args.fmus, args.t_end, args.step)
        runs = {"FMPy Gauss-Seidel": fmpy_master(args.fmus, args.t_end, args.step),
                "FMPy Jacobi": fmpy_master(args.fmus, args.t_end, args.step, "jacobi"),
                "ecospy (SSP)": ecospy_run(ssp, args.t_end, args.step)}
        if not args.no_libcosim:
            runs["libcosimpy"] = libcosimpy_run(args.fmus, args.t_end, args.step)
    print(f"h = {args.step:g} s, {args.t_end:g} s; error: max |x - x_mono| / max |x_mono|")
    for name, result in runs.items():
        print(f"  {name:20s} {relative_error(result, mono):9.3e}")
    jacobi = runs["FMPy Jacobi"]
    for name in ("ecospy (SSP)", "libcosimpy"):
        if name in runs:
            print(f"  {name} vs FMPy Jacobi: {relative_error(runs[name], jacobi):.3e}")


if __name__ == "__main__":
    main()
