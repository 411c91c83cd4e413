"""Scene: every parameter of the model, with SI units, allowed ranges and validation.

The defaults are the article's Figure 2 scene (Table 1 and Section 4.1): a 1600 kg structure with
k = 1 MN/m and c = 0.2 kN.s/m, struck by a 1600 kg floe of 1 m^2 drag area pushed by a 0.1 m/s
current, linearised drag with v_lin = 0.1 m/s (b = 49.95 kg/s, eq. 30), perfectly elastic impacts.

Names follow the FMU interface (``structure.m`` is ``Scene.structure_m`` and so on); see
:data:`PARAMETERS` for the table of names, units and ranges.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

LINEAR_DRAG = 1
QUADRATIC_DRAG = 2

METHOD_EXACT = 1
METHOD_FIXED_STEP = 2
METHOD_ODE = 3

DETECTION_WINDOW = 1
DETECTION_SIGN = 2


class ParameterError(ValueError):
    """A parameter is outside its allowed range; the message names it, its value and the range."""

    def __init__(self, name: str, value: Any, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name} = {value!r} is not allowed: {allowed}")


@dataclass(frozen=True)
class ParameterSpec:
    """One row of the parameter table: FMI name, unit, meaning and allowed range (as text)."""

    name: str
    field: str
    unit: str
    description: str
    allowed: str
    kind: type = float
    minimum: float | None = None
    maximum: float | None = None


PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("structure.m", "structure_m", "kg", "structure mass", "> 0", minimum=0.0),
    ParameterSpec("structure.c", "structure_c", "N.s/m", "structure viscous damping", ">= 0",
                  minimum=0.0),
    ParameterSpec("structure.k", "structure_k", "N/m", "structure stiffness", "> 0", minimum=0.0),
    ParameterSpec("structure.x0", "structure_x0", "m", "initial structure displacement", "finite"),
    ParameterSpec("structure.v0", "structure_v0", "m/s", "initial structure velocity", "finite"),
    ParameterSpec("ice.M", "ice_M", "kg", "ice (free) mass", "> 0", minimum=0.0),
    ParameterSpec("ice.A", "ice_A", "m2", "ice drag area", "> 0", minimum=0.0),
    ParameterSpec("ice.Cd", "ice_Cd", "1", "ice drag coefficient", ">= 0", minimum=0.0),
    ParameterSpec("ice.z0", "ice_z0", "m", "initial ice displacement (upstream of the structure)",
                  "finite and <= structure.x0"),
    ParameterSpec("ice.v0", "ice_v0", "m/s", "initial ice velocity", "finite"),
    ParameterSpec("fluid.rho", "fluid_rho", "kg/m3", "fluid density", "> 0", minimum=0.0),
    ParameterSpec("impact.e", "impact_e", "1", "coefficient of restitution (eq. 13)",
                  "0 <= e <= 1", minimum=0.0, maximum=1.0),
    ParameterSpec("drag.model", "drag_model", "", "drag law: 1 = linearised (eq. 4), "
                  "2 = quadratic (eq. 3)", "1 or 2", kind=int, minimum=1, maximum=2),
    ParameterSpec("drag.v_lin", "drag_v_lin", "m/s", "linearisation speed of the drag (eq. 5)",
                  "> 0", minimum=0.0),
    ParameterSpec("solver.method", "solver_method", "", "1 = exact event-driven, "
                  "2 = fixed-step (the article's scheme), 3 = ODE (scipy)", "1, 2 or 3",
                  kind=int, minimum=1, maximum=3),
    # dt >= 1 ns: a smaller grid needs over 1e9 points per simulated second (minutes of work per
    # second) and its grid times lose their precision
    ParameterSpec("solver.dt", "solver_dt", "s", "internal step of method 2", ">= 1e-9",
                  minimum=1e-9),
    # rtol >= 1e-13: scipy raises anything below 100 machine epsilons to 2.2e-14 anyway, and
    # atol = 1e-3 rtol must stay above the rounding of the states
    ParameterSpec("solver.rtol", "solver_rtol", "1", "relative tolerance of method 3",
                  "1e-13 <= rtol < 1", minimum=1e-13, maximum=1.0),
    ParameterSpec("solver.detection", "solver_detection", "", "impact test of method 2: "
                  "1 = tolerance window (eq. 26), 2 = sign change of the gap", "1 or 2",
                  kind=int, minimum=1, maximum=2),
    ParameterSpec("solver.ode_method", "solver_ode_method", "", "integrator of method 3: "
                  "1 = RK45, 2 = DOP853, 3 = LSODA, 4 = Radau", "1, 2, 3 or 4",
                  kind=int, minimum=1, maximum=4),
)

FLOW_INPUT = ParameterSpec("flow.u", "flow_u", "m/s",
                           "flow speed, positive towards the structure", "finite")

_BY_NAME = {p.name: p for p in PARAMETERS}
#: Every FMI-named value a scene holds: the parameters and the flow input's start value.
SPECS_BY_NAME: dict[str, ParameterSpec] = {**_BY_NAME, FLOW_INPUT.name: FLOW_INPUT}
_BY_FIELD = {p.field: p for p in PARAMETERS}


@dataclass(frozen=True)
class Scene:
    """All parameters of one simulation, SI units, defaults = the article's Figure 2 scene."""

    structure_m: float = 1600.0
    structure_c: float = 200.0
    structure_k: float = 1.0e6
    structure_x0: float = 0.0
    structure_v0: float = 0.0
    ice_M: float = 1600.0
    ice_A: float = 1.0
    ice_Cd: float = 1.0
    ice_z0: float = -0.01
    ice_v0: float = 0.01
    fluid_rho: float = 999.0
    impact_e: float = 1.0
    drag_model: int = LINEAR_DRAG
    drag_v_lin: float = 0.1
    flow_u: float = 0.1
    solver_method: int = METHOD_EXACT
    solver_dt: float = 1.0e-4
    solver_rtol: float = 1.0e-8
    solver_detection: int = DETECTION_WINDOW
    solver_ode_method: int = 2

    def __post_init__(self) -> None:
        validate(self)

    # Derived quantities -----------------------------------------------------------------------
    @property
    def drag_B(self) -> float:
        """Quadratic drag constant B = rho Cd A / 2 in kg/m (eq. 33)."""
        return 0.5 * self.fluid_rho * self.ice_Cd * self.ice_A

    @property
    def drag_b(self) -> float:
        """Linearised drag constant b = rho Cd A v_lin / 2 in kg/s (eq. 5, eq. 30)."""
        return self.drag_B * self.drag_v_lin

    @property
    def omega_n(self) -> float:
        """Natural circular frequency sqrt(k/m) of the structure, rad/s."""
        return math.sqrt(self.structure_k / self.structure_m)

    @property
    def zeta(self) -> float:
        """Damping ratio c / (2 sqrt(k m)) of the structure."""
        return self.structure_c / (2.0 * math.sqrt(self.structure_k * self.structure_m))

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_fmi(self) -> dict[str, float | int]:
        """The parameters (and the flow input start value) keyed by FMI variable name."""
        out: dict[str, float | int] = {p.name: getattr(self, p.field) for p in PARAMETERS}
        out[FLOW_INPUT.name] = self.flow_u
        return out

    def replace_fmi(self, values: dict[str, Any]) -> Scene:
        """A copy with FMI-named values changed (``{"ice.M": 800.0, "flow.u": 0.5}``)."""
        return dataclasses.replace(self, **_fields(values))

    @classmethod
    def from_fmi(cls, values: dict[str, Any]) -> Scene:
        """Build a scene from FMI-named values (``{"ice.M": 800.0, ...}``); others keep defaults."""
        return cls(**_fields(values))


def _fields(values: dict[str, Any]) -> dict[str, Any]:
    """FMI-named values keyed by Scene field; an unknown name is a ParameterError."""
    fields: dict[str, Any] = {}
    for name, value in values.items():
        if name not in SPECS_BY_NAME:
            raise ParameterError(name, value, "no such parameter; known: "
                                 + ", ".join(sorted(_BY_NAME) + [FLOW_INPUT.name]))
        fields[SPECS_BY_NAME[name].field] = value
    return fields


def _check_number(spec: ParameterSpec, value: Any) -> None:
    if spec.kind is int:
        if (isinstance(value, bool) or not isinstance(value, int | float)
                or not math.isfinite(value) or value != int(value)):
            raise ParameterError(spec.name, value, f"an integer, {spec.allowed}")
        if not spec.minimum <= value <= spec.maximum:
            raise ParameterError(spec.name, value, spec.allowed)
        return
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ParameterError(spec.name, value, f"a real number, {spec.allowed}")
    if not math.isfinite(value):
        raise ParameterError(spec.name, value, f"finite, {spec.allowed}")
    strict_low = spec.allowed.startswith(">") and not spec.allowed.startswith(">=")
    if spec.minimum is not None:
        if value < spec.minimum or (strict_low and value == spec.minimum):
            raise ParameterError(spec.name, value, spec.allowed)
    if spec.name == "solver.rtol" and value >= 1.0:
        raise ParameterError(spec.name, value, spec.allowed)
    if spec.maximum is not None and value > spec.maximum:
        raise ParameterError(spec.name, value, spec.allowed)


def validate_flow(u: Any, scene: Scene | None = None) -> float:
    """Check a flow speed (m/s): a finite real whose drag force and kinetic energy on the ice of
    ``scene`` (if given) are finite numbers. Returns it as float."""
    if isinstance(u, bool) or not isinstance(u, int | float) or not math.isfinite(u):
        raise ParameterError(FLOW_INPUT.name, u, "a finite real number (m/s)")
    u = float(u)
    if scene is not None:
        drag = scene.drag_B * u * u if scene.drag_model == QUADRATIC_DRAG else scene.drag_b * u
        if not (math.isfinite(drag) and math.isfinite(0.5 * scene.ice_M * u * u)):
            raise ParameterError(FLOW_INPUT.name, u, "a flow speed whose drag force on the ice "
                                 "and kinetic energy of the ice are finite (" + _OVERFLOW + ")")
    return u


#: The explicit Euler step of the quadratic drag (eq. 36) maps r = w - u to r (1 - q |r|) with
#: q = (B/M) dt: |r| grows (and overflows) once q |r| exceeds this (method 2).
EULER_STABILITY_LIMIT = 2.0

#: Why a combination of finite parameters can still be refused.
_OVERFLOW = "this scene's scales overflow double precision"


def _check_scales(scene: Scene) -> None:
    """Refuse combinations of valid parameters whose derived scales are not finite numbers.

    Each parameter may be within its range while a rate the solvers use overflows (k/m = inf
    gives omega_n = inf and NaN states) or underflows to 0; such scenes have no meaningful
    simulation, so they get an error naming the combination rather than NaN outputs.
    """
    s = scene
    linear = s.drag_model == LINEAR_DRAG
    b = s.drag_b if linear else 0.0  # the linearised drag constant only matters for drag law 1
    zeta_together = (s.structure_c + b) / (2.0 * math.sqrt(s.structure_k
                                                           * (s.structure_m + s.ice_M)))
    checks = [
        ("structure.k / structure.m", s.structure_k / s.structure_m,
         "omega_n^2 = k/m (1/s^2) finite and > 0", True),
        ("structure.c / structure.m", s.structure_c / s.structure_m, "c/m (1/s) finite", False),
        ("fluid.rho * ice.Cd * ice.A / 2", s.drag_B, "the drag constant B (kg/m) finite", False),
        ("B / ice.M", s.drag_B / s.ice_M, "the drag rate B/M (1/m) finite", False),
        ("B * drag.v_lin / ice.M", b / s.ice_M, "the drag rate b/M (1/s) finite", False),
        ("zeta^2 = (structure.c / (2 sqrt(k m)))^2", s.zeta * s.zeta,
         "the squared damping ratio of the structure finite", False),
        ("zeta^2 = ((structure.c + b) / (2 sqrt(k (m + M))))^2 (bodies in contact)",
         zeta_together * zeta_together,
         "the squared damping ratio of the bodies moving together finite", False),
        ("structure.k * structure.x0^2 / 2", 0.5 * s.structure_k * s.structure_x0 * s.structure_x0,
         "the initial strain energy (J) finite", False),
        ("structure.m * structure.v0^2 / 2", 0.5 * s.structure_m * s.structure_v0 * s.structure_v0,
         "the initial kinetic energy of the structure (J) finite", False),
        ("ice.M * ice.v0^2 / 2", 0.5 * s.ice_M * s.ice_v0 * s.ice_v0,
         "the initial kinetic energy of the ice (J) finite", False),
    ]
    for name, value, allowed, positive in checks:
        if not math.isfinite(value) or (positive and value <= 0.0):
            raise ParameterError(name, value, f"{allowed}: {_OVERFLOW}")


def validate(scene: Scene) -> None:
    """Raise :class:`ParameterError` for the first parameter outside its allowed range, then for
    combinations whose derived scales overflow (see :func:`_check_scales`)."""
    for spec in PARAMETERS:
        _check_number(spec, getattr(scene, spec.field))
    validate_flow(scene.flow_u)
    if scene.ice_z0 > scene.structure_x0:
        raise ParameterError("ice.z0", scene.ice_z0,
                             f"<= structure.x0 = {scene.structure_x0!r} (the ice starts upstream)")
    _check_scales(scene)
    validate_flow(scene.flow_u, scene)
    if scene.solver_method == METHOD_FIXED_STEP and scene.drag_model == QUADRATIC_DRAG:
        relative = abs(scene.ice_v0 - scene.flow_u)
        rate = scene.drag_B / scene.ice_M * relative  # 1/s
        if rate * scene.solver_dt > EULER_STABILITY_LIMIT:
            raise ParameterError(
                "solver.dt", scene.solver_dt,
                f"< {EULER_STABILITY_LIMIT:g} M / (B |ice.v0 - flow.u|) = "
                f"{EULER_STABILITY_LIMIT / rate:.3g} s with quadratic drag and "
                "solver.method = 2: a longer explicit Euler step (eq. 36) diverges")


def load_scene(path: str | Path) -> Scene:
    """Load a scene from a TOML file.

    Keys are the FMI names, either dotted at top level (``"ice.M" = 800``) or as tables::

        [structure]
        m = 1600.0
        [ice]
        M = 800.0
        [flow]
        u = 0.1

    Unknown keys are an error (a typo must not silently fall back to a default).
    """
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    flat: dict[str, Any] = {}

    def walk(prefix: str, table: dict[str, Any]) -> None:
        for key, value in table.items():
            name = f"{prefix}.{key}" if prefix else key
            if isinstance(value, dict):
                walk(name, value)
            else:
                flat[name] = value

    walk("", data)
    return Scene.from_fmi(flat)
