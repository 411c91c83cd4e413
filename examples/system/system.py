"""An ice floe striking a structure from another FMU: IceImpact.fmu (structure.model = 2) coupled
to ModalStructure.fmu, in scripted masters and in five masters that load one system file.

The system (``IceOnStructure.ssp``, written by :func:`iceimpact.fmi.ssp.write_ssp`, the same
function the build writes it with; components ``floe`` and ``structure``)::

    floe.coupling.force -> structure.force
    structure.x         -> floe.structure.x_in
    structure.v         -> floe.structure.v_in
    structure.a         -> floe.structure.a_in

The SSP carries ``SystemStructure.ssd`` (parameters bound inline, OpenModelica's fixed-step master,
a DefaultExperiment of 2 s with the OSP step of 1 ms), both FMUs and the same parameters as
``resources/IceOnStructure.ssv`` under ``resources/``; docs/coupling.md says which master needs
which part. Every master that loads it is a Jacobi scheme, so it binds ``coupling.scheme = 2``.

The masters (fixed communication step h), each with IceImpact's ``coupling.scheme`` set to its
scheme:

- ``fmpy_master(..., scheme="gauss-seidel")``: a scripted loop over FMPy's ``FMU2Slave``, ice
  first: the ice steps against the structure's state at the step start, then the structure steps
  with the ice's force of that same step (the scheme of tests/coupling_master.py;
  ``coupling.scheme = 1``);
- ``fmpy_master(..., scheme="jacobi")``: both step from the values of the previous step end, then
  the outputs are passed on (the structure's force is one step older; ``coupling.scheme = 2``);
- ``libcosimpy_run``: the same system built by hand in libcosim (libcosimpy), a Jacobi scheme;
- loading the SSP unchanged, all Jacobi: ``fmpy_ssp_run`` (FMPy's ``simulate_ssp``),
  ``ecospy_run`` (ECOS), ``libcosim_ssp_run`` (libcosim's ``from_ssp_file``),
  ``omsimulator_cli_run`` and ``omsimulator_api_run`` (OMSimulator's command line and Python
  API; the OMSimulator build is found at ``../shared/tools/omsimulator`` from the repository by
  default, and skipped where absent).

Every run returns a dict: ``time``, ``x`` (the structure's), ``force`` (the floe's
contact.force) at the communication points k h, ``count`` (contact.count at the end); the SSP
masters also ``counts`` (contact.count at each point).

Run ``python examples/system/system.py --fmus dist`` after ``python build_fmu.py``: it writes the
SSP, runs every master, prints how far each is from IceImpact's own monolithic run (the built-in
structure, structure.model = 1, equal to the default mode of ModalStructure.fmu) and the
agreement of the masters with the FMPy Jacobi loop.
"""

from __future__ import annotations

import argparse
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

# the system, its scene and its file, as the build writes it beside the FMUs
from iceimpact.fmi.ssp import (  # noqa: F401  (CONNECTIONS: the connections, for the tests)
    COMPONENTS,
    CONNECTIONS,
    FLOW_U,
    ICE,
    ICE_COMPONENT,
    INTEGERS,
    PARAMETER_SET,
    SCHEMES,
    SSV,
    STEP,
    STRUCTURE,
    STRUCTURE_COMPONENT,
    T_END,
    bindings,
    connections,
    experiment,
    write_ssp,
)

ROOT = Path(__file__).resolve().parents[2]
#: An OMSimulator build (bin/OMSimulator, python/OMSimulator): ../shared/tools/omsimulator
OMSIMULATOR = ROOT.parent / "shared" / "tools" / "omsimulator"


def _communication_points(time: np.ndarray, columns: dict, t_end: float, h: float) -> dict:
    """The values at the communication points 0, h, ..., t_end of a master whose clock adds h
    up (t += h: FMPy's simulate_ssp, OMSimulator) or counts nanoseconds (libcosim): its k-th
    point is taken for k h; a point beyond (an extra step to reach t_end with the summed
    clock a little short of it) is left out."""
    n = round(t_end / h)
    if len(time) < n + 1 or np.max(np.abs(time[:n + 1] - np.arange(n + 1) * h)) > h / 2:
        raise RuntimeError(f"the master's time points are not 0, h, ..., {t_end} s "
                           f"(h = {h} s): {time[:3]} ... {time[-3:]}")
    return {"time": time[:n + 1], **{k: v[:n + 1] for k, v in columns.items()}}


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
    ice_fmu = Slave(fmus / "IceImpact.fmu", ICE_COMPONENT,
                    {**ice, "coupling.scheme": SCHEMES[scheme], "flow.u": flow_u})
    st = Slave(fmus / "ModalStructure.fmu", STRUCTURE_COMPONENT, structure)
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


# The masters that read the SSP --------------------------------------------------------------------
def _floe(name: str) -> str:
    return f"{ICE_COMPONENT}.{name}"


def _structure(name: str) -> str:
    return f"{STRUCTURE_COMPONENT}.{name}"


def fmpy_ssp_run(ssp: Path, t_end: float | None = None,
                 h: float | None = None) -> dict[str, np.ndarray]:
    """The SSP through FMPy's ``simulate_ssp`` (Jacobi: every component steps, then the
    connections are applied), with the SSP's own parameter set (FMPy applies no inline
    binding); ``t_end`` and ``h`` by default the SSP's."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import read_ssv

    _, stop, step = experiment(ssp)
    t_end, h = t_end or stop, h or step
    rows = simulate_ssp(str(ssp), stop_time=t_end, step_size=h,
                        parameter_set=read_ssv(str(ssp), resource=SSV))
    # a row holds the time at the start of a step and the outputs at its end; before the first
    # step the system is at rest (x = 0, no force) in this scene
    time = np.r_[0.0, rows["time"] + h]
    return _ssp_result(time, np.r_[0.0, rows[_structure("x")]],
                       np.r_[0.0, rows[_floe("contact.force")]],
                       np.r_[0, rows[_floe("contact.count")]], t_end, h)


def _ssp_result(time, x, force, counts, t_end: float, h: float) -> dict:
    result = _communication_points(np.asarray(time, dtype=float),
                                   {"x": np.asarray(x, dtype=float),
                                    "force": np.asarray(force, dtype=float),
                                    "counts": np.asarray(counts).astype(int)}, t_end, h)
    result["count"] = int(result["counts"][-1])
    return result


def ecospy_run(ssp: Path, t_end: float | None = None,
               h: float | None = None) -> dict[str, np.ndarray]:
    """The SSP through ECOS (its Jacobi fixed-step algorithm), parameter set ``initialValues``;
    ``t_end`` and ``h`` by default the SSP's."""
    import ecospy

    _, stop, step = experiment(ssp)
    t_end, h = t_end or stop, h or step
    x_name, force_name = f"{STRUCTURE_COMPONENT}::x", f"{ICE_COMPONENT}::contact.force"
    count_name = f"{ICE_COMPONENT}::contact.count"
    rows: list[tuple[float, float, float, int]] = []

    def row() -> tuple[float, float, float, int]:
        return (sim.get_time(), sim.get_real(x_name), sim.get_real(force_name),
                sim.get_integer(count_name))

    class Recorder(ecospy.SimulationListener):
        def post(self, info):
            rows.append(row())

    with ecospy.EcosSimulation(ssp_path=str(ssp), step_size=h) as sim:
        sim.add_listener("recorder", Recorder())
        sim.init(parameter_set=PARAMETER_SET)
        rows.append((0.0, *row()[1:]))
        sim.step(round(t_end / h))
        sim.terminate()
    time, x, force, counts = (np.array(column) for column in zip(*rows, strict=True))
    return {"time": time, "x": x, "force": force, "counts": counts, "count": int(counts[-1])}


def libcosim_ssp_run(ssp: Path, t_end: float | None = None) -> dict[str, np.ndarray]:
    """The SSP through libcosim's own SSP loader, ``CosimExecution.from_ssp_file(path)`` with no
    step size: the step is the SSP's OSP annotation, the parameters its inline set (the
    first set of each component is libcosim's default). Its fixed-step algorithm is Jacobi;
    its clock counts integer nanoseconds. ``t_end`` by default the SSP's."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    _, stop, h = experiment(ssp)
    t_end = t_end or stop
    # its debug log is a page per FMU; a warning (a binding it could not apply) still shows
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(str(ssp))
    index = {name: execution.slave_index_from_instance_name(name)
             for name in (ICE_COMPONENT, STRUCTURE_COMPONENT)}
    refs = {name: {v.name.decode(): v.reference for v in execution.slave_variables(i)}
            for name, i in index.items()}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    floe, structure = index[ICE_COMPONENT], index[STRUCTURE_COMPONENT]
    rows = [(0.0, 0.0, 0.0, 0)]  # at rest before the first step, which it reports nothing of
    for _ in range(round(t_end / h)):
        execution.step()
        rows.append((execution.status().current_time * 1e-9,
                     observer.last_real_values(structure, [refs[STRUCTURE_COMPONENT]["x"]])[0],
                     observer.last_real_values(floe, [refs[ICE_COMPONENT]["contact.force"]])[0],
                     observer.last_integer_values(
                         floe, [refs[ICE_COMPONENT]["contact.count"]])[0]))
    time, x, force, counts = zip(*rows, strict=True)
    return _ssp_result(time, x, force, counts, t_end, h)


def read_mat(path: Path) -> dict[str, np.ndarray]:
    """An OpenModelica result file (what OMSimulator writes as .mat): name -> values, a
    parameter as its [start, end] pair."""
    from scipy.io import loadmat

    mat = loadmat(str(path), chars_as_strings=False)
    names = ["".join(column).rstrip("\x00 ") for column in mat["name"].T]
    data = {1: mat["data_1"], 2: mat["data_2"], 0: mat["data_2"]}  # 0: the time itself
    return {name: np.sign(column) * data[block][abs(column) - 1]
            for name, block, column in zip(names, *mat["dataInfo"][:2], strict=True)}


def _omsimulator_result(mat: dict, prefix: str, t_end: float, h: float) -> dict:
    """The communication points of an OMSimulator result and the floe's bound parameters as
    the FMU had them. OMSimulator writes every time point twice (before and after passing the
    outputs on): the last of each is kept."""
    time = mat["time"]
    last = np.r_[time[1:] != time[:-1], True]
    result = _ssp_result(time[last], mat[prefix + _structure("x")][last],
                         mat[prefix + _floe("contact.force")][last],
                         mat[prefix + _floe("contact.count")][last], t_end, h)
    result["parameters"] = {name[len(prefix) + len(ICE_COMPONENT) + 1:]: values[0]
                            for name, values in mat.items()
                            if name.startswith(prefix + ICE_COMPONENT + ".") and len(values) == 2}
    return result


def omsimulator_cli_run(ssp: Path, omsimulator: Path = OMSIMULATOR,
                        t_end: float | None = None) -> dict:
    """The SSP through OMSimulator's command line (``bin/OMSimulator`` of the build
    ``omsimulator``): its fixed-step master (oms-ma, Jacobi) at the SSP's step. The command line
    sets the stop time itself (default 1 s): ``--stopTime`` is the SSP's ``t_end`` unless
    given. A binding OMSimulator cannot apply is an ``error:`` line in its output, exit status
    0: that raises RuntimeError."""
    executable = Path(omsimulator) / "bin" / "OMSimulator"
    if not executable.is_file():
        raise FileNotFoundError(f"no OMSimulator at {executable}")
    _, stop, h = experiment(ssp)
    t_end = t_end or stop
    with tempfile.TemporaryDirectory() as tmp:
        # it unpacks the SSP into a folder of its working directory
        done = subprocess.run([str(executable), str(Path(ssp).resolve()), f"--stopTime={t_end!r}",
                               "--resultFile=result.mat"], cwd=tmp, capture_output=True,
                              text=True, timeout=600)
        log = done.stdout + done.stderr
        if done.returncode != 0 or "error:" in log:
            raise RuntimeError(f"OMSimulator failed (exit status {done.returncode}):\n{log}")
        mat = read_mat(Path(tmp) / "result.mat")
    # names are the model's, the system's, then the component's
    return _omsimulator_result(mat, "IceOnStructure.IceOnStructure.", t_end, h)


#: What OMSimulator's Python API (3.0) leaves out of a bound name: every dot-separated part
#: equal to a part of the instance's path, model.root.<component> (InstantiatedModel.validatePath)
_OMS_API_PATH = ("model", "root")


def omsimulator_api_run(ssp: Path, omsimulator: Path = OMSIMULATOR,
                        t_end: float | None = None) -> dict:
    """The SSP through OMSimulator's Python API (``SSP(path).instantiate()``, the package in
    ``python/`` of the build ``omsimulator``), its fixed-step master (Jacobi) at the SSP's step.

    The API drops each part of a bound name that is also a part of the instance's path
    (``model``, ``root``, the component's name): ``structure.model`` and ``drag.model`` would
    become ``structure`` and ``drag``, unknown, and the instantiation crashes. No form of the
    SSP avoids it (inline, an SSV file or a system-level binding all go that way), so those
    bindings, as the SSP has them, are taken out before ``instantiate()`` and set through the
    instantiated model's ``setValue``, which maps the names correctly. Its master takes no step
    size from the SSP: it is set to the SSP's. Run it in a process of its own: a failure in
    OMSimulator may end the process."""
    package = Path(omsimulator) / "python"
    if not (package / "OMSimulator").is_dir():
        raise FileNotFoundError(f"no OMSimulator Python package in {package}")
    if str(package) not in sys.path:
        sys.path.insert(0, str(package))
    from OMSimulator import SSP, CRef
    from OMSimulator.component import Component

    _, stop, h = experiment(ssp)
    t_end = t_end or stop
    with tempfile.TemporaryDirectory() as tmp:
        # OMSimulator's own temporary folders go in there (the instance's is never removed)
        saved, tempfile.tempdir = tempfile.tempdir, tmp
        try:
            model = SSP(str(ssp))
            system = model.activeVariant.system
            deferred = []
            for name, element in system.elements.items():
                if isinstance(element, Component):
                    path = {*_OMS_API_PATH, str(name)}
                    for key in list(element.value.start_values):
                        if path & set(str(key).split(".")):
                            value = element.value.start_values.pop(key)[0]
                            deferred.append((CRef(system.name, str(name), str(key)), value))
            instance = model.instantiate()
        finally:
            tempfile.tempdir = saved
        try:
            for cref, value in deferred:
                instance.setValue(cref, value)
            instance.setFixedStepSize(h)
            instance.setStopTime(t_end)
            instance.setResultFile(str(Path(tmp) / "result.mat"))
            instance.initialize()
            instance.simulate()
        finally:
            # a model left alive is terminated at exit, after Python may be gone
            try:
                instance.terminate()
            finally:
                instance.delete()
        mat = read_mat(Path(tmp) / "result.mat")
    result = _omsimulator_result(mat, "IceOnStructure.", t_end, h)
    result["deferred"] = sorted(cref.names[-1] for cref, _ in deferred)
    return result


def libcosimpy_run(fmus: Path, t_end: float, h: float, ice: dict = ICE,
                   structure: dict = STRUCTURE, flow_u: float = FLOW_U,
                   second_order: bool = True) -> dict[str, np.ndarray]:
    """The same system in libcosim (fixed-step algorithm, Jacobi), built by hand."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    # its debug log is a page per FMU; warnings and errors still show
    log_output_level(CosimLogLevel.WARNING)
    nanos = round(h * 1e9)
    execution = CosimExecution.from_step_size(step_size=nanos)
    slaves = {name: execution.add_local_slave(CosimLocalSlave(str(fmus / fmu), name))
              for name, fmu in ((ICE_COMPONENT, "IceImpact.fmu"),
                                (STRUCTURE_COMPONENT, "ModalStructure.fmu"))}
    refs = {}
    for name, index in slaves.items():
        refs[name] = {v.name.decode(): v.reference
                      for v in execution.slave_variables(index)}
    for name, values in bindings(ice, structure, flow_u).items():
        for key, value in values.items():
            if key in INTEGERS:
                execution.integer_initial_value(slaves[name], refs[name][key], int(value))
            else:
                execution.real_initial_value(slaves[name], refs[name][key], float(value))
    for role_a, ca, role_b, cb in connections(second_order):
        a, b = COMPONENTS[role_a], COMPONENTS[role_b]
        execution.connect_real_variables(slaves[a], refs[a][ca], slaves[b], refs[b][cb])
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    n = round(t_end / h)
    floe, structure_index = slaves[ICE_COMPONENT], slaves[STRUCTURE_COMPONENT]
    rows = []
    for _ in range(n):
        execution.step()
        rows.append((
            observer.last_real_values(structure_index, [refs[STRUCTURE_COMPONENT]["x"]])[0],
            observer.last_real_values(floe, [refs[ICE_COMPONENT]["contact.force"]])[0]))
    x = [0.0] + [r[0] for r in rows]
    force = [0.0] + [r[1] for r in rows]
    t = np.arange(n + 1) * h
    count = observer.last_integer_values(floe, [refs[ICE_COMPONENT]["contact.count"]])[0]
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
    parser.add_argument("--t-end", type=float, default=T_END)
    parser.add_argument("--step", type=float, default=STEP)
    parser.add_argument("--no-libcosim", action="store_true")
    parser.add_argument("--omsimulator", type=Path, default=OMSIMULATOR,
                        help="OMSimulator build with bin/ and python/ (default: "
                             "../shared/tools/omsimulator from the repository)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ssp = write_ssp(args.fmus, args.ssp or Path(tmp) / "IceOnStructure.ssp",
                        t_end=args.t_end, h=args.step)
        print(f"wrote {ssp}")
        mono = monolithic(args.fmus, args.t_end, args.step)
        runs = {"FMPy Gauss-Seidel": fmpy_master(args.fmus, args.t_end, args.step),
                "FMPy Jacobi": fmpy_master(args.fmus, args.t_end, args.step, "jacobi"),
                "FMPy simulate_ssp": fmpy_ssp_run(ssp),
                "ecospy (SSP)": ecospy_run(ssp)}
        if not args.no_libcosim:
            runs["libcosimpy"] = libcosimpy_run(args.fmus, args.t_end, args.step)
            runs["libcosim (SSP)"] = libcosim_ssp_run(ssp)
        if (args.omsimulator / "bin" / "OMSimulator").is_file():
            runs["OMSimulator CLI"] = omsimulator_cli_run(ssp, args.omsimulator)
            # its own process: OMSimulator may end the process it runs in
            runs["OMSimulator API"] = in_subprocess("omsimulator_api_run", ssp,
                                                     args.omsimulator)
        else:
            print(f"OMSimulator skipped: no build at {args.omsimulator}")
    print(f"h = {args.step:g} s, {args.t_end:g} s; error: max |x - x_mono| / max |x_mono|")
    for name, result in runs.items():
        print(f"  {name:20s} {relative_error(result, mono):9.3e}  impacts {result['count']}")
    jacobi = runs["FMPy Jacobi"]
    for name, result in runs.items():
        if name not in ("FMPy Gauss-Seidel", "FMPy Jacobi"):
            print(f"  {name} vs FMPy Jacobi: {relative_error(result, jacobi):.3e}")


def in_subprocess(function: str, *args, timeout: float = 600) -> dict:
    """``function(*args)`` of this module in a child process, so that a crash there (libcosim
    and OMSimulator may end the process they run in) is a RuntimeError here; the arguments and
    the result go through pickle files."""
    with tempfile.TemporaryDirectory() as tmp:
        call, out = Path(tmp) / "call.pickle", Path(tmp) / "result.pickle"
        call.write_bytes(pickle.dumps((function, args)))
        code = ("import pickle, sys; from pathlib import Path; "
                "import system; name, args = pickle.loads(Path(sys.argv[1]).read_bytes()); "
                "Path(sys.argv[2]).write_bytes(pickle.dumps(getattr(system, name)(*args)))")
        # this folder first on the child's path: it imports this module by name
        paths = [str(Path(__file__).resolve().parent),
                 *filter(None, [os.environ.get("PYTHONPATH")])]
        done = subprocess.run([sys.executable, "-c", code, str(call), str(out)],
                              capture_output=True, text=True, timeout=timeout,
                              env={**os.environ, "PYTHONPATH": os.pathsep.join(paths)})
        if done.returncode != 0 or not out.is_file():
            raise RuntimeError(f"{function} failed (exit status {done.returncode}):\n"
                               f"{done.stdout[-5000:]}{done.stderr[-5000:]}")
        return pickle.loads(out.read_bytes())


if __name__ == "__main__":
    main()
