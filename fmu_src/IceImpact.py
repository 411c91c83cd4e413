"""IceImpact: the FMI 2.0 Co-Simulation slave (PythonFMU) around :class:`iceimpact.Simulator`.

This file only maps FMI variables onto the model core; the physics lives in the ``iceimpact``
package, bundled under ``resources/`` by ``build_fmu.py``. The variable names, units and meanings
are the contract of ``docs/fmu.md``.

Two rules shape the code:

* **No exception may leave a slave method.** PythonFMU turns any Python exception into
  ``fmi2Fatal`` and, in doing so, releases its references to the instance; a later
  ``fmi2FreeInstance`` releases them again and can crash the host. Every failure is therefore
  logged (variable, value, allowed range) and reported through ``do_step`` returning False, which
  PythonFMU maps to ``fmi2Discard``.
* **Parameters take effect at ``exitInitializationMode``** (or at the first ``doStep`` if a master
  skips initialization); ``impact.e`` is tunable and takes effect from the next step.
"""

from __future__ import annotations

import ctypes
import math
import os
import pickle
import sys
from dataclasses import dataclass
from typing import Any

from pythonfmu import (
    Boolean,
    DefaultExperiment,
    Fmi2Causality,
    Fmi2Initial,
    Fmi2Slave,
    Fmi2Variability,
    Integer,
    Real,
)
from pythonfmu.enums import Fmi2Status

from iceimpact import ParameterError, Scene, Simulator, SolverError
from iceimpact.scene import DETECTION_WINDOW, FLOW_INPUT, METHOD_FIXED_STEP, PARAMETERS
from iceimpact_fmu_boot import fail_call

# PythonFMU 0.7.0's native loader (findClass in PySlaveInstance.cpp) runs this module's source a
# second time for every fmi2Instantiate and then calls Py_DECREF on the *borrowed* module
# dictionary: each instantiation steals one reference from it. Today that is hidden by a leak in
# the same function (the classes of every re-execution are never released, and their methods keep
# the dictionary alive); should the leak be fixed alone, the dictionary would be freed while in
# use after enough instantiations. The line below runs on import and on each re-execution (its
# name lookup falls through to the module globals) and gives one reference back per stolen one.
globals().setdefault("_MODULE_DICT_REFS", []).append(globals())

MODEL_IDENTIFIER = "IceImpact"

# Libraries (paths of loaded copies of binaries/linux64/IceImpact.so) already guarded below.
_GUARDED_LIBRARIES: set[str] = set()


def guard_native_exit() -> None:
    """Work around a use-after-free at process exit in PythonFMU 0.7.0's native library.

    The library keeps the embedded interpreter in a static ``std::shared_ptr<PyState>``. At
    ``exit()`` the C++ static destructor of that pointer runs first (it finalizes Python and frees
    the PyState), then the library's ``__attribute__((destructor))`` assigns ``nullptr`` to the
    already destroyed pointer, which decrements a counter inside the freed block and corrupts the
    malloc free lists. The process then aborts or segfaults in a later ``free`` at exit (with
    numpy/scipy loaded: in libgfortran's exit-time ``close_units``). The library is never really
    unloaded (its GNU_UNIQUE symbols make it NODELETE), so this happens at process exit whether or
    not the host calls ``dlclose``.

    The fix: for each loaded copy of the library, register ``finalizePythonInterpreter`` (exported
    by the library) with ``__cxa_atexit``. Being registered after the library's static
    constructors, it runs before the static destructor and releases the PyState while the pointer
    is still alive; the destructor and the library destructor then find a null pointer. The library
    is pinned with RTLD_NODELETE so the registered function stays mapped.
    """
    if not sys.platform.startswith("linux"):
        return
    suffix = f"/{MODEL_IDENTIFIER}.so"
    try:
        with open("/proc/self/maps") as maps:
            fields = [line.rstrip("\n").split(None, 5) for line in maps]
        new = {f[5] for f in fields if len(f) == 6 and f[5].endswith(suffix)}
        new -= _GUARDED_LIBRARIES
        if not new:
            return
        cxa_atexit = ctypes.CDLL(None).__cxa_atexit
        cxa_atexit.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        cxa_atexit.restype = ctypes.c_int
        for path in sorted(new):
            _GUARDED_LIBRARIES.add(path)
            try:
                lib = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_NODELETE | os.RTLD_NOW)
                finalize = ctypes.cast(lib.finalizePythonInterpreter, ctypes.c_void_p).value
            except (OSError, AttributeError):
                continue  # not a PythonFMU library after all
            cxa_atexit(finalize, None, None)
    except Exception:  # never fail an instantiation over this
        return


@dataclass(frozen=True)
class OutputSpec:
    """One output: FMI name, field of :class:`iceimpact.StepReport`, type, unit, meaning."""

    name: str
    field: str
    kind: type
    unit: str
    description: str
    minimum: float | None = None
    discrete: bool = False  # a Real that changes only at events (impacts)


OUTPUTS: tuple[OutputSpec, ...] = (
    OutputSpec("structure.x", "x", float, "m", "structure displacement"),
    OutputSpec("structure.v", "v", float, "m/s", "structure velocity"),
    OutputSpec("ice.z", "z", float, "m", "ice displacement"),
    OutputSpec("ice.v", "w", float, "m/s", "ice velocity"),
    OutputSpec("contact.gap", "gap", float, "m",
               "gap x - z between structure and ice, never negative", minimum=0.0),
    OutputSpec("contact.impulse", "impulse", float, "N.s",
               "impulse delivered to the structure during the last communication step "
               "(impacts plus sticking contact)"),
    OutputSpec("contact.force", "force", float, "N",
               "mean contact force over the last communication step: contact.impulse / step size"),
    OutputSpec("contact.count", "impact_count", int, "", "impacts since the start", minimum=0),
    OutputSpec("contact.active", "sticking", bool, "", "true while the bodies stick together"),
    OutputSpec("contact.t_last", "t_last", float, "s",
               "time of the latest impact (-1 before the first)", discrete=True),
    # appended after the original outputs, so that their value references stay unchanged
    OutputSpec("contact.penetration", "penetration", float, "m",
               "distance the ice is past the structure (z - x > 0), else 0: the fixed-step "
               "method's grid (solver.method = 2), or the ODE method's integration error (3, "
               "of the order of its absolute tolerance, 1e-3 solver.rtol m); always 0 with the "
               "exact method", minimum=0.0),
)

TUNABLE = frozenset({"impact.e"})

# A master's communication point may differ from the sum of the step sizes by rounding only.
_TIME_RTOL = 1e-9

_STATE_VERSION = 1


def variable_units() -> dict[str, str]:
    """Unit of every Real variable of the FMU, keyed by name (used by ``build_fmu.py``)."""
    units = {p.name: p.unit for p in PARAMETERS if p.kind is float}
    units[FLOW_INPUT.name] = FLOW_INPUT.unit
    units.update({o.name: o.unit for o in OUTPUTS if o.kind is float})
    return units


def _fmi_text(message: str) -> str:
    # FMI loggers treat the message as a printf format string.
    return message.replace("%", "%%")


class IceImpact(Fmi2Slave):
    """Flow-driven repeated ice impacts on a flexible structure (FMI 2.0 Co-Simulation)."""

    author = "IceImpact contributors"
    description = ("Flow-driven repeated ice impacts on a flexible structure: a damped SDOF "
                   "structure struck by an ice floe pushed by the current")
    license = "MIT"
    version = "0.2.0"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=400.0, step_size=1e-3)

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        guard_native_exit()
        defaults = Scene()
        self._values: dict[str, float | int] = {p.name: getattr(defaults, p.field)
                                                for p in PARAMETERS}
        self._flow_u = float(defaults.flow_u)
        self._sim: Simulator | None = None
        self._scene: Scene | None = None
        self._report = Simulator(defaults).report
        self._start_time = 0.0
        self._time = 0.0
        self._pending_e: float | None = None
        self._error: str | None = None  # why the instance cannot step (invalid parameters)
        self._penetration_logged = False  # the warning on the ice passing the structure

        for spec in PARAMETERS:
            variability = (Fmi2Variability.tunable if spec.name in TUNABLE
                           else Fmi2Variability.fixed)
            var_type = Integer if spec.kind is int else Real
            self.register_variable(var_type(
                spec.name, causality=Fmi2Causality.parameter, variability=variability,
                description=spec.description, getter=self._parameter_getter(spec.name),
                setter=self._parameter_setter(spec.name)), nested=False)

        self.register_variable(Real(
            FLOW_INPUT.name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
            description=FLOW_INPUT.description, getter=lambda: self._flow_u,
            setter=self._set_flow), nested=False)

        for out in OUTPUTS:
            var_type = {float: Real, int: Integer, bool: Boolean}[out.kind]
            variability = (Fmi2Variability.continuous if out.kind is float and not out.discrete
                           else Fmi2Variability.discrete)
            self.register_variable(var_type(
                out.name, causality=Fmi2Causality.output, variability=variability,
                initial=Fmi2Initial.calculated, description=out.description,
                getter=self._output_getter(out)), nested=False)

    # Variable access -----------------------------------------------------------------------------
    def _parameter_getter(self, name: str):
        return lambda: self._values[name]

    def _parameter_setter(self, name: str):
        def setter(value: Any) -> None:
            self._values[name] = value
            if self._sim is None:
                return
            if name in TUNABLE:
                self._pending_e = value  # validated and applied by the next doStep
            else:
                self._log(Fmi2Status.warning,
                          f"{name} is a fixed parameter: the new value {value!r} is ignored after "
                          "initialization (use fmi2Reset to change it)")
        return setter

    def _set_flow(self, value: Any) -> None:
        self._flow_u = value

    def _output_getter(self, out: OutputSpec):
        field = out.field
        if field == "t_last":
            def t_last() -> float:
                t = self._report.t_last
                return t + self._start_time if t >= 0.0 else -1.0
            return t_last
        return lambda: getattr(self._report, field)

    def _log(self, status: Fmi2Status, message: str) -> None:
        self.log(_fmi_text(message), status)

    # FMI life cycle ------------------------------------------------------------------------------
    def setup_experiment(self, start_time: float, stop_time: float | None,
                         tolerance: float | None) -> None:
        if isinstance(start_time, int | float) and math.isfinite(start_time):
            self._start_time = float(start_time)
            self._time = float(start_time)
        else:
            self._error = (f"start time = {start_time!r} is not allowed: a finite number of "
                           "seconds")
            self._log(Fmi2Status.error, self._error)

    def exit_initialization_mode(self) -> None:
        self._create_simulator("exitInitializationMode")

    def _create_simulator(self, where: str) -> bool:
        """Build the Simulator from the parameters; on failure log why and remember it."""
        if self._error is not None:
            return False
        try:
            scene = Scene.from_fmi({**self._values, FLOW_INPUT.name: self._flow_u})
            sim = Simulator(scene)
        except ParameterError as exc:
            self._error = f"{where}: {exc}"
        except Exception as exc:  # a defect in the core must not kill the host
            self._error = f"{where}: cannot create the simulator: {exc!r}"
        else:
            self._scene, self._sim = scene, sim
            self._report = sim.report
            self._pending_e = None
            self._penetration_logged = False
            return True
        self._log(Fmi2Status.error, self._error + "; the FMU will not step (fmi2Error) until "
                  "the parameter is corrected after fmi2Reset")
        return False

    def do_step(self, current_time: float, step_size: float) -> bool:
        try:
            return self._do_step(current_time, step_size)
        except Exception as exc:  # never let an exception reach PythonFMU (see module docstring)
            self._log(Fmi2Status.error, f"doStep at t = {current_time!r} s failed: {exc!r}")
            return False

    def _do_step(self, current_time: float, step_size: float) -> bool:
        if self._sim is None and not self._create_simulator("doStep"):
            fail_call(self, _fmi_text(f"doStep refused: {self._error}"))  # fmi2Error
            return False
        if not (math.isfinite(step_size) and step_size > 0.0):
            self._log(Fmi2Status.error, f"doStep: communication step size = {step_size!r} s is "
                      "not allowed: finite and > 0")
            return False
        expected = self._time
        if not (math.isfinite(current_time)
                and abs(current_time - expected) <= _TIME_RTOL * max(1.0, abs(expected))):
            self._log(Fmi2Status.error, f"doStep: current communication point = {current_time!r}"
                      f" s does not match the time of the FMU, {expected!r} s (the end of the "
                      "last step)")
            return False
        sim = self._sim
        if self._pending_e is not None:
            try:
                sim.set_restitution(self._pending_e)
            except ParameterError as exc:
                self._log(Fmi2Status.error, f"doStep: {exc}")
                return False
            self._pending_e = None
        try:
            report = sim.advance(step_size, self._flow_u)
        except (ParameterError, SolverError) as exc:  # a SolverError stops the run for good
            self._log(Fmi2Status.error, f"doStep at t = {current_time!r} s: {exc}")
            return False
        if not all(math.isfinite(getattr(report, o.field)) for o in OUTPUTS
                   if o.kind is float):
            self._log(Fmi2Status.error, f"doStep at t = {current_time!r} s: the model produced a "
                      f"non-finite output ({report!r}); outputs keep their previous values")
            return False
        self._report = report
        self._time = current_time + step_size
        if report.penetration > 0.0 and not self._penetration_logged:
            self._penetration_logged = True
            if self._scene.solver_method == METHOD_FIXED_STEP:
                why = ("the fixed-step method tests impacts on its grid points only" +
                       (" and its eq. 26 window (solver.detection = 1) misses impacts"
                        if self._scene.solver_detection == DETECTION_WINDOW else ""))
            else:
                why = ("the ODE method's positions carry its integration error (absolute "
                       "tolerance 1e-3 solver.rtol m, exceeded a few times at most)")
            self._log(Fmi2Status.warning, f"doStep at t = {current_time!r} s: the ice is "
                      f"{report.penetration:.3g} m past the structure (contact.penetration): "
                      f"{why}; solver.method = 1 locates every impact exactly (logged once)")
        return True

    # FMU state (fmi2GetFMUstate / fmi2SetFMUstate / serialization) -------------------------------
    def _get_fmu_state(self) -> dict[str, Any]:
        try:
            return {
                "version": _STATE_VERSION,
                "values": dict(self._values),
                "flow_u": self._flow_u,
                "scene": self._scene,
                "sim": self._sim.save() if self._sim is not None else None,
                "report": self._report,
                "start_time": self._start_time,
                "time": self._time,
                "pending_e": self._pending_e,
                "error": self._error,
            }
        except Exception as exc:
            self._log(Fmi2Status.error, f"fmi2GetFMUstate failed: {exc!r}")
            return {"version": None, "error": f"fmi2GetFMUstate failed: {exc!r}"}

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        try:
            if not isinstance(state, dict) or state.get("version") != _STATE_VERSION:
                reason = state.get("error") if isinstance(state, dict) else None
                raise ValueError(reason or "not a state of this FMU")
            sim = None
            scene = state["scene"]
            if state["sim"] is not None:
                # A snapshot holds the whole simulator state (scene included): any Simulator can
                # take it, e.g. in an instance that was never initialized.
                sim = self._sim if self._sim is not None else Simulator(scene)
                sim.restore(state["sim"])
            self._values = dict(state["values"])
            self._flow_u = state["flow_u"]
            self._scene, self._sim = scene, sim
            self._report = state["report"]
            self._start_time = state["start_time"]
            self._time = state["time"]
            self._pending_e = state["pending_e"]
            self._error = state["error"]
        except Exception as exc:
            self._log(Fmi2Status.error, f"fmi2SetFMUstate failed, the state is unchanged: {exc!r}")

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any]) -> bytes:
        try:
            return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # reported by _set_fmu_state when these bytes come back
            return pickle.dumps({"version": None, "error": f"serialization failed: {exc!r}"})

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> dict[str, Any]:
        try:
            return pickle.loads(state)
        except Exception:
            return {"version": None}  # rejected (and logged) by _set_fmu_state
