"""Shared by the FMU tests: the FMU built once per test session, and a hand-stepped instance.

``Instance`` drives an FMU2Slave call by call, keeps every log message with its status, and turns
FMPy's exceptions for non-OK statuses back into status codes, so that tests can assert on them.
FMPy is imported by what uses it, so that the module imports where FMPy is not installed.
"""

from __future__ import annotations

import importlib.util
import itertools
import math
import os
import weakref
from ctypes import byref
from pathlib import Path

import numpy as np

from iceimpact.contract import OUTPUTS

ROOT = Path(__file__).resolve().parents[1]
#: The folder of these helpers.
HELPERS = Path(__file__).resolve().parent

DT = 1e-3
REAL_OUTPUTS = [o for o in OUTPUTS if o.kind is float]
FMI_OK, FMI_WARNING, FMI_DISCARD, FMI_ERROR = 0, 1, 2, 3


def helpers_env() -> dict[str, str]:
    """This process's environment with the helpers' folder first on PYTHONPATH: a child Python
    given it imports fmu_host and the other helpers by name."""
    paths = [str(HELPERS), *filter(None, [os.environ.get("PYTHONPATH")])]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}


def toolbox_check(fmu: Path) -> tuple[list[str], str, list[str]]:
    """fmu-manipulation-toolbox's checkers (``fmutool -check``: the FMI 2.0 or 3.0 schema and the
    standard's rules beyond it) on ``fmu``: the warnings and errors they log, the FMI version
    the schema check found the FMU compliant with, and the semantic check's errors."""
    import logging

    from fmu_manipulation_toolbox.checker import (
        OperationGenericCheck,
        OperationSemanticCheck,
        get_checkers,
    )
    from fmu_manipulation_toolbox.operations import FMU

    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = records.append
    logger = logging.getLogger("fmu_manipulation_toolbox")
    logger.addHandler(handler)
    checkers = [checker() for checker in get_checkers()]
    try:
        with FMU(str(fmu)) as archive:
            for checker in checkers:
                archive.apply_operation(checker)
    finally:
        logger.removeHandler(handler)
    generic = next(c for c in checkers if isinstance(c, OperationGenericCheck))
    semantic = next(c for c in checkers if isinstance(c, OperationSemanticCheck))
    return [r.getMessage() for r in records], generic.compliant_with_version, semantic.errors


def build_module():
    """build_fmu.py imported as a module."""
    spec = importlib.util.spec_from_file_location("build_fmu", ROOT / "build_fmu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# FMPy's logger proxy (fmpy.logging.addLoggerProxy: a C function that formats the printf-style
# message, which a ctypes callback cannot) holds ONE Python logger for the whole process. Each call
# replaces it, and every proxied callback structure, FMPy's own default one that simulate_fmu uses
# included, forwards to the latest. A logger closure per Instance was therefore left dangling once
# its Instance was collected: the next message of any FMU run through FMPy's proxy (a warning of a
# later simulate_fmu, which the FMU reports whatever loggingOn says) jumped into freed memory and
# crashed the process; meanwhile every Instance's messages went to the newest Instance. So there is
# one logger, alive as long as the process, which finds the Instance by the componentEnvironment
# of its callbacks and prints anything else the way FMPy's default logger does.
_INSTANCES: weakref.WeakValueDictionary[int, Instance] = weakref.WeakValueDictionary()
_INSTANCE_KEYS = itertools.count(1)


def _log(env, instance, status, category, message):
    target = _INSTANCES.get(env) if env else None
    if target is None:
        from fmpy.fmi1 import printLogMessage

        printLogMessage(env, instance, status, category, message)
    else:
        target.messages.append((status, (category or b"").decode(), message.decode()))


_LOGGER = []  # the one ctypes logger, never freed: FMPy's proxy may call it at any time


def _logger():
    """The ctypes logger of every Instance, made at the first."""
    if not _LOGGER:
        from fmpy.fmi2 import fmi2CallbackLoggerTYPE

        _LOGGER.append(fmi2CallbackLoggerTYPE(_log))
    return _LOGGER[0]


class Instance:
    """An FMU2Slave stepped by hand, with a logger that keeps (status, category, message)."""

    def __init__(self, fmu_dir: str, md, name: str = "instance"):
        self.messages: list[tuple[int, str, str]] = []

        from fmpy import calloc, free
        from fmpy.fmi2 import (
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
        )
        from fmpy.logging import addLoggerProxy

        key = next(_INSTANCE_KEYS)
        _INSTANCES[key] = self
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = _logger()
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        callbacks.componentEnvironment = key
        addLoggerProxy(byref(callbacks))  # makes _logger() FMPy's one logger (again)
        self._callbacks = callbacks  # must outlive the instance
        self.variables = {v.name: v for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=fmu_dir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
        self.time = 0.0

    def set(self, values: dict) -> None:
        for name, value in values.items():
            var = self.variables[name]
            if var.type == "Integer":
                self.fmu.setInteger([var.valueReference], [value])
            else:
                self.fmu.setReal([var.valueReference], [value])

    def initialize(self, values: dict | None = None, start: float = 0.0) -> int:
        self.fmu.setupExperiment(startTime=start)
        self.set(values or {})
        self.fmu.enterInitializationMode()
        self.time = start
        return self.fmu.exitInitializationMode()

    def step(self, t: float, h: float) -> int:
        """doStep; returns the status instead of raising."""
        from fmpy.fmi1 import FMICallException

        try:
            self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        except FMICallException as exc:
            return exc.status
        return FMI_OK  # FMPy raises for statuses above fmi2Warning

    def run(self, n: int, start_index: int = 0) -> list[dict]:
        """n steps on the grid k*DT from step start_index; the outputs after each."""
        rows = []
        for k in range(start_index, start_index + n):
            t0, t1 = k * DT, (k + 1) * DT
            assert self.step(t0, t1 - t0) == FMI_OK, self.messages
            rows.append(self.outputs())
        return rows

    def outputs(self) -> dict:
        """Every output, in one FMI get call per type."""
        groups = {kind: [o for o in OUTPUTS if o.kind is kind] for kind in (float, int, bool)}
        getters = {float: self.fmu.getReal, int: self.fmu.getInteger, bool: self.fmu.getBoolean}
        out = {}
        for kind, outs in groups.items():
            values = getters[kind]([self.variables[o.name].valueReference for o in outs])
            out.update({o.name: v for o, v in zip(outs, values, strict=True)})
        return out

    def free(self) -> None:
        self.fmu.freeInstance()


def columns(rows: list[dict]) -> dict[str, np.ndarray]:
    return {o.name: np.array([r[o.name] for r in rows]) for o in OUTPUTS}


def errors(inst: Instance) -> str:
    return "\n".join(m for status, _, m in inst.messages if status >= FMI_DISCARD)


def assert_outputs_finite(inst: Instance) -> None:
    out = inst.outputs()
    assert all(math.isfinite(out[o.name]) for o in REAL_OUTPUTS), out
