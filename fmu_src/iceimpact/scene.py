"""Scene: every parameter of the model, with SI units, allowed ranges and validation.

The defaults are the article's Figure 2 scene (Table 1 and Section 4.1): a 1600 kg structure with
k = 1 MN/m and c = 0.2 kN.s/m, struck by a 1600 kg floe of 1 m^2 drag area pushed by a 0.1 m/s
current, linearised drag with v_lin = 0.1 m/s (b = 49.95 kg/s, eq. 30), perfectly elastic impacts.

Names follow the FMU interface (``structure.m`` is ``Scene.structure_m`` and so on); see
:data:`PARAMETERS` for the table of names, units and ranges.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .contract import (
    DETECTION_SIGN,
    DETECTION_WINDOW,
    FLOW_INPUT,
    INPUTS,
    LINEAR_DRAG,
    METHOD_EXACT,
    METHOD_FIXED_STEP,
    METHOD_ODE,
    MODE_LOAD_INPUTS,
    PARAMETERS,
    QUADRATIC_DRAG,
    SCENE_VARIABLES,
    SCHEME_JACOBI,
    STRUCTURE_EXTERNAL,
    STRUCTURE_INPUTS,
    STRUCTURE_MODAL,
    Variable,
)
from .errors import ParameterError, real_number, value_text
from .limits import (
    EULER_STABILITY_LIMIT,
    MODAL_RATE_MAX,
    OVERFLOW,
    check_sticking_rate,
    check_structure_drag_rate,
    check_work,
    drag_rate,
    drag_rate_text,
    integrates_quadratic_drag,
    integrates_taylor_sticking,
    rate_limit,
)

__all__ = ["DETECTION_SIGN", "DETECTION_WINDOW", "FLOW_INPUT", "LINEAR_DRAG", "METHOD_EXACT",
           "METHOD_FIXED_STEP", "METHOD_ODE", "PARAMETERS", "QUADRATIC_DRAG", "SPECS_BY_NAME",
           "ParameterError", "ParameterSpec", "Scene", "load_scene", "validate", "validate_flow"]

#: A parameter's row of the contract (kept under its older name).
ParameterSpec = Variable


#: Every FMI-named value a scene holds: the parameters and the flow input's start value.
SPECS_BY_NAME: dict[str, Variable] = SCENE_VARIABLES
_START = {v.field: v.start for v in PARAMETERS + INPUTS}


@dataclass(frozen=True)
class Scene:
    """All parameters of one simulation, SI units, defaults = the article's Figure 2 scene."""

    structure_m: float = _START["structure_m"]
    structure_c: float = _START["structure_c"]
    structure_k: float = _START["structure_k"]
    structure_x0: float = _START["structure_x0"]
    structure_v0: float = _START["structure_v0"]
    ice_M: float = _START["ice_M"]
    ice_A: float = _START["ice_A"]
    ice_Cd: float = _START["ice_Cd"]
    ice_z0: float = _START["ice_z0"]
    ice_v0: float = _START["ice_v0"]
    fluid_rho: float = _START["fluid_rho"]
    impact_e: float = _START["impact_e"]
    drag_model: int = _START["drag_model"]
    drag_v_lin: float = _START["drag_v_lin"]
    flow_u: float = _START["flow_u"]
    solver_method: int = _START["solver_method"]
    solver_dt: float = _START["solver_dt"]
    solver_rtol: float = _START["solver_rtol"]
    solver_detection: int = _START["solver_detection"]
    solver_ode_method: int = _START["solver_ode_method"]
    structure_model: int = _START["structure_model"]
    structure_x_in: float = _START["structure_x_in"]
    structure_v_in: float = _START["structure_v_in"]
    structure_a_in: float = _START["structure_a_in"]
    coupling_scheme: int = _START["coupling_scheme"]
    structure_Ca: float = _START["structure_Ca"]
    structure_V: float = _START["structure_V"]
    structure_Cd: float = _START["structure_Cd"]
    structure_A: float = _START["structure_A"]
    solver_max_impacts: int = _START["solver_max_impacts"]
    solver_max_evaluations: int = _START["solver_max_evaluations"]
    solver_chatter_fraction: float = _START["solver_chatter_fraction"]
    # the modal structure (structure.model = 3): mode k's f (Hz), zeta, m (kg), phi, q0 (m),
    # v0 (m/s), and its generalized load (N, an input)
    structure_modes: int = _START["structure_modes"]
    structure_mode1_f: float = _START["structure_mode1_f"]
    structure_mode1_zeta: float = _START["structure_mode1_zeta"]
    structure_mode1_m: float = _START["structure_mode1_m"]
    structure_mode1_phi: float = _START["structure_mode1_phi"]
    structure_mode1_q0: float = _START["structure_mode1_q0"]
    structure_mode1_v0: float = _START["structure_mode1_v0"]
    structure_mode2_f: float = _START["structure_mode2_f"]
    structure_mode2_zeta: float = _START["structure_mode2_zeta"]
    structure_mode2_m: float = _START["structure_mode2_m"]
    structure_mode2_phi: float = _START["structure_mode2_phi"]
    structure_mode2_q0: float = _START["structure_mode2_q0"]
    structure_mode2_v0: float = _START["structure_mode2_v0"]
    structure_mode3_f: float = _START["structure_mode3_f"]
    structure_mode3_zeta: float = _START["structure_mode3_zeta"]
    structure_mode3_m: float = _START["structure_mode3_m"]
    structure_mode3_phi: float = _START["structure_mode3_phi"]
    structure_mode3_q0: float = _START["structure_mode3_q0"]
    structure_mode3_v0: float = _START["structure_mode3_v0"]
    structure_mode4_f: float = _START["structure_mode4_f"]
    structure_mode4_zeta: float = _START["structure_mode4_zeta"]
    structure_mode4_m: float = _START["structure_mode4_m"]
    structure_mode4_phi: float = _START["structure_mode4_phi"]
    structure_mode4_q0: float = _START["structure_mode4_q0"]
    structure_mode4_v0: float = _START["structure_mode4_v0"]
    structure_mode5_f: float = _START["structure_mode5_f"]
    structure_mode5_zeta: float = _START["structure_mode5_zeta"]
    structure_mode5_m: float = _START["structure_mode5_m"]
    structure_mode5_phi: float = _START["structure_mode5_phi"]
    structure_mode5_q0: float = _START["structure_mode5_q0"]
    structure_mode5_v0: float = _START["structure_mode5_v0"]
    structure_mode1_load: float = _START["structure_mode1_load"]
    structure_mode2_load: float = _START["structure_mode2_load"]
    structure_mode3_load: float = _START["structure_mode3_load"]
    structure_mode4_load: float = _START["structure_mode4_load"]
    structure_mode5_load: float = _START["structure_mode5_load"]
    structure_load_order: int = _START["structure_load_order"]

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
    def added_mass(self) -> float:
        """Morison added mass m_a = rho Ca V of the structure, kg (0: off;
        docs/explanation/morison.md)."""
        return self.fluid_rho * self.structure_Ca * self.structure_V

    @property
    def structure_mass(self) -> float:
        """Mass that moves with the structure, m + m_a, kg: its inertia in eq. 8 and in the
        impact law (eq. 12-17), the added mass moving with it (docs/explanation/morison.md).
        With the modal structure (structure.model = 3), the mass its contact point opposes to an
        impulse, :attr:`effective_mass`."""
        if self.structure_model == STRUCTURE_MODAL:
            return self.effective_mass
        return self.structure_m + self.added_mass

    # the modal structure (structure.model = 3) ---------------------------------------------------
    @property
    def modal(self) -> bool:
        """The structure is the built-in modal one (structure.model = 3)."""
        return self.structure_model == STRUCTURE_MODAL

    @property
    def mode_table(self) -> tuple[tuple[float, float, float, float, float, float], ...]:
        """The modes used, ``(f, zeta, m, phi, q0, v0)`` each (Hz, 1, kg, 1, m, m/s): modes 1 to
        structure.modes."""
        return tuple(tuple(getattr(self, f"structure_mode{k}_{name}") for name in _MODE_FIELDS)
                     for k in range(1, self.structure_modes + 1))

    @property
    def mode_loads(self) -> tuple[float, ...]:
        """The generalized loads of the modes used (N): the inputs structure.mode<k>.load."""
        return tuple(getattr(self, f"structure_mode{k}_load")
                     for k in range(1, self.structure_modes + 1))

    @property
    def effective_mass(self) -> float:
        """The mass the modal structure's contact point opposes to an impulse, kg:
        ``1 / sum(phi_k^2 / m_k)`` over the modes used (docs/explanation/modes.md)."""
        return 1.0 / _modal_flexibility(self)

    @property
    def contact_stiffness(self) -> float:
        """The structure's static stiffness at the ice contact point, N/m: the force that,
        applied there statically, holds the contact point at a unit displacement. The SDOF's
        ``structure.k`` (given for the external structure too, whose ``structure.force`` is 0);
        with the modal structure ``1 / sum(phi_k^2 / k_k)``, ``k_k = m_k (2 pi f_k)^2``, over the
        modes used (one mode with phi = 1: m omega^2, the SDOF's k). Its product with x is the
        structural load ``structure.force`` and the design loads' k x: with the modes a
        quasi-static equivalent load at the contact point, without their own dynamic
        amplification of member forces (docs/explanation/modes.md)."""
        if self.structure_model == STRUCTURE_MODAL:
            return 1.0 / _modal_compliance(self)
        return self.structure_k

    @property
    def modal_start(self) -> tuple[float, float]:
        """The modal structure's contact point at the start, ``(sum phi q0, sum phi v0)``."""
        x = v = 0.0
        for _, _, _, phi, q0, v0 in self.mode_table:  # (summed in mode order: fixed rounding)
            x += phi * q0
            v += phi * v0
        return x, v

    @property
    def structure_drag_B(self) -> float:
        """Quadratic Morison drag constant of the structure B_s = rho Cd_s A_s / 2, kg/m."""
        return 0.5 * self.fluid_rho * self.structure_Cd * self.structure_A

    @property
    def structure_drag_b(self) -> float:
        """Linearised drag constant of the structure b_s = B_s drag.v_lin, kg/s."""
        return self.structure_drag_B * self.drag_v_lin

    @property
    def structure_drag_on(self) -> bool:
        """The flow drags the structure (structure.Cd structure.A > 0)."""
        return self.structure_drag_B > 0.0

    @property
    def morison_on(self) -> bool:
        """Either Morison term on the structure is on (added mass or drag)."""
        return self.added_mass > 0.0 or self.structure_drag_on

    @property
    def omega_n(self) -> float:
        """Natural circular frequency sqrt(k / (m + m_a)) of the structure, rad/s (sqrt(k/m)
        without added mass). With the modal structure, the highest 2 pi f_k of the modes seen
        at the contact point (phi_k != 0): the time scale the contact rules resolve."""
        if self.structure_model == STRUCTURE_MODAL:
            return max(2.0 * math.pi * f for f, _, _, phi, _, _ in self.mode_table if phi != 0.0)
        return math.sqrt(self.structure_k / self.structure_mass)

    @property
    def zeta(self) -> float:
        """Damping ratio c / (2 sqrt(k (m + m_a))) of the structure (structural damping only)."""
        return self.structure_c / (2.0 * math.sqrt(self.structure_k * self.structure_mass))

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_fmi(self) -> dict[str, float | int]:
        """The parameters (and the inputs' start values) keyed by FMI variable name."""
        out: dict[str, float | int] = {p.name: getattr(self, p.field) for p in PARAMETERS}
        for v in INPUTS:
            out[v.name] = getattr(self, v.field)
        return out

    @property
    def external(self) -> bool:
        """The structure lives in another FMU (structure.model = 2)."""
        return self.structure_model == STRUCTURE_EXTERNAL

    @property
    def jacobi(self) -> bool:
        """An external structure coupled by a Jacobi master (coupling.scheme = 2): the structure
        feels a step's contact force over the next step."""
        return self.external and self.coupling_scheme == SCHEME_JACOBI

    def replace_fmi(self, values: dict[str, Any]) -> Scene:
        """A copy with FMI-named values changed (``{"ice.M": 800.0, "flow.u": 0.5}``)."""
        return dataclasses.replace(self, **_fields(values))

    @classmethod
    def from_fmi(cls, values: dict[str, Any]) -> Scene:
        """Build a scene from FMI-named values (``{"ice.M": 800.0, ...}``); others keep defaults."""
        return cls(**_fields(values))


_MODE_FIELDS = ("f", "zeta", "m", "phi", "q0", "v0")


def _modal_flexibility(scene: Scene) -> float:
    """``sum phi_k^2 / m_k`` over the modes used, 1/kg, summed in mode order."""
    total = 0.0
    for _, _, m, phi, _, _ in scene.mode_table:
        total += phi * phi / m
    return total


def _modal_compliance(scene: Scene) -> float:
    """``sum phi_k^2 / k_k``, ``k_k = m_k (2 pi f_k)^2`` (the modes' stiffnesses as the modal
    solvers form them), over the modes used, m/N, summed in mode order."""
    total = 0.0
    for f, _, m, phi, _, _ in scene.mode_table:
        omega = 2.0 * math.pi * f
        total += phi * phi / (m * omega * omega)
    return total


def _check_modes(scene: Scene) -> None:
    """The modal structure (structure.model = 3): a contact point that some mode moves, an
    effective mass and modal rates that are finite numbers, Morison terms off (not modelled on
    several modes), the ice upstream of the contact point."""
    s = scene
    if s.morison_on:
        name, value = (("structure.Ca", s.structure_Ca) if s.added_mass != 0.0
                       else ("structure.Cd", s.structure_Cd))
        raise ParameterError(name, value, "0 with structure.model = 3: Morison loads on the modal "
                             "structure are not modelled (the drag at the contact point would "
                             "couple the modes' damping); give the fluid's added mass and "
                             "damping to the modes (modal mass, zeta), or use structure.model = 1")
    if all(phi == 0.0 for _, _, _, phi, _, _ in s.mode_table):
        raise ParameterError("structure.mode1.phi", s.structure_mode1_phi,
                             f"not 0 for at least one of the {s.structure_modes} modes used "
                             "(structure.modes): no mode moves the contact point")
    flexibility = _modal_flexibility(s)
    if not (math.isfinite(flexibility) and flexibility > 0.0
            and math.isfinite(1.0 / flexibility)):
        raise ParameterError("1 / sum(structure.mode<k>.phi^2 / structure.mode<k>.m)",
                             1.0 / flexibility if flexibility else math.inf,
                             f"the effective mass at the contact point (kg) finite and > 0: "
                             f"{OVERFLOW}")
    for k, (f, zeta, m, phi, q0, v0) in enumerate(s.mode_table, start=1):
        omega = 2.0 * math.pi * f
        rate = omega * (zeta + math.sqrt(zeta * zeta + 1.0))
        if rate > MODAL_RATE_MAX:
            raise ParameterError(
                f"2 pi structure.mode{k}.f (zeta + sqrt(zeta^2 + 1))", rate,
                f"<= {MODAL_RATE_MAX:g} 1/s: the riding ice's Taylor steps span at most 4 / rate "
                "each, so a faster mode costs seconds of CPU per simulated second of riding; leave "
                "out modes far above the frequencies the impacts excite "
                "(docs/how-to/put-my-structure-in.md)")
        checks = (
            (f"(2 pi structure.mode{k}.f)^2", omega * omega, "omega_k^2 (1/s^2) finite and > 0"),
            (f"2 structure.mode{k}.zeta 2 pi structure.mode{k}.f", 2.0 * zeta * omega,
             "the mode's damping rate (1/s) finite"),
            (f"structure.mode{k}.m (2 pi structure.mode{k}.f)^2", m * omega * omega,
             "the mode's stiffness (N/m) finite and > 0"),
            (f"structure.mode{k}.m (2 pi f q0)^2 / 2", 0.5 * m * (omega * q0) ** 2,
             "the mode's initial strain energy (J) finite"),
            (f"structure.mode{k}.m v0^2 / 2", 0.5 * m * v0 * v0,
             "the mode's initial kinetic energy (J) finite"),
            (f"structure.mode{k}.phi structure.mode{k}.q0", phi * q0,
             "the mode's share of the contact point's displacement (m) finite"),
        )
        for name, value, allowed in checks:
            if not math.isfinite(value) or ("> 0" in allowed and value <= 0.0):
                raise ParameterError(name, value, f"{allowed}: {OVERFLOW}")
    compliance = _modal_compliance(s)  # (each mode's stiffness is finite and > 0 by now)
    stiffness = 1.0 / compliance if compliance > 0.0 else math.inf
    if not (math.isfinite(stiffness) and stiffness > 0.0):
        raise ParameterError("1 / sum(structure.mode<k>.phi^2 / (structure.mode<k>.m "
                             "(2 pi structure.mode<k>.f)^2))", stiffness,
                             f"the static stiffness at the contact point (N/m), the factor of "
                             f"structure.force, finite and > 0: {OVERFLOW}")
    x0, _ = s.modal_start
    if s.ice_z0 > x0:
        raise ParameterError("ice.z0", s.ice_z0, f"<= sum phi q0 = {x0!r}, the contact point at "
                             "the start (the ice starts upstream)")


def _fields(values: dict[str, Any]) -> dict[str, Any]:
    """FMI-named values keyed by Scene field; an unknown name is a ParameterError."""
    fields: dict[str, Any] = {}
    for name, value in values.items():
        spec = SPECS_BY_NAME.get(name)
        if spec is None:
            raise ParameterError(name, value, unknown_name_hint(name))
        fields[spec.field] = value
    return fields


def unknown_name_hint(name: str) -> str:
    """The 'allowed' text for a name that is no parameter: the closest names, then all."""
    close = difflib.get_close_matches(str(name), list(SPECS_BY_NAME), n=3, cutoff=0.6)
    hint = f"did you mean {' or '.join(close)}? " if close else ""
    return f"no such parameter; {hint}known: " + ", ".join(sorted(SPECS_BY_NAME))


def _check_number(spec: Variable, value: Any) -> float | int:
    """``value`` of the parameter or input ``spec`` checked, as the Python number a scene
    holds: an int for an Integer, a float for a Real (from Python and numpy numbers alike,
    :func:`~iceimpact.errors.real_number`)."""
    number = real_number(value)
    if spec.kind is int:
        if number is None or not math.isfinite(number) or number != int(number):
            raise ParameterError(spec.name, value, f"an integer, {spec.allowed}")
        if not spec.in_range(number):
            raise ParameterError(spec.name, value, spec.allowed)
        return int(number)
    if number is None:
        raise ParameterError(spec.name, value, f"a real number, {spec.allowed}")
    if not math.isfinite(number):
        within = "a real number within double precision" if isinstance(value, int) else "finite"
        raise ParameterError(spec.name, value, f"{within}, {spec.allowed}")
    if not spec.in_range(number):
        raise ParameterError(spec.name, value, spec.allowed)
    return number


def _hold(scene: Scene, field: str, value: float | int) -> None:
    """Keep the checked ``value`` in the (frozen) scene where the one given was another type
    (a numpy number, an int for a Real): its arithmetic is then Python's, in double precision."""
    if getattr(scene, field).__class__ is not value.__class__:
        object.__setattr__(scene, field, value)


def validate_flow(u: Any, scene: Scene | None = None) -> float:
    """Check a flow speed (m/s): a finite real whose drag force and kinetic energy on the ice of
    ``scene`` (if given) are finite numbers. Returns it as float."""
    number = real_number(u)
    if number is None or not math.isfinite(number):
        raise ParameterError(FLOW_INPUT.name, u, "a finite real number (m/s)")
    u = number
    if scene is not None:
        drag = scene.drag_B * u * u if scene.drag_model == QUADRATIC_DRAG else scene.drag_b * u
        if not (math.isfinite(drag) and math.isfinite(0.5 * scene.ice_M * u * u)):
            raise ParameterError(FLOW_INPUT.name, u, "a flow speed whose drag force on the ice "
                                 "and kinetic energy of the ice are finite (" + OVERFLOW + ")")
        if integrates_quadratic_drag(scene) and drag_rate(scene, abs(u)) > rate_limit(scene):
            limit = rate_limit(scene) * scene.ice_M / (2.0 * scene.drag_B)
            raise ParameterError(FLOW_INPUT.name, u, drag_rate_text(scene, limit, "|flow.u|"))
        if scene.structure_drag_on:
            force = (scene.structure_drag_B * u * u if scene.drag_model == QUADRATIC_DRAG
                     else scene.structure_drag_b * u)
            if not math.isfinite(force):
                raise ParameterError(FLOW_INPUT.name, u, "a flow speed whose Morison drag force "
                                     "on the structure is finite (" + OVERFLOW + ")")
            check_structure_drag_rate(scene, abs(u), FLOW_INPUT.name)
        if integrates_taylor_sticking(scene):
            check_sticking_rate(scene, abs(u), u)
    return u


def _check_scales(scene: Scene) -> None:
    """Refuse combinations of valid parameters whose derived scales are not finite numbers.

    Each parameter may be within its range while a rate the solvers use overflows (k/m = inf
    gives omega_n = inf and NaN states) or underflows to 0; such scenes have no meaningful
    simulation, so they get an error naming the combination rather than NaN outputs.
    """
    s = scene
    linear = s.drag_model == LINEAR_DRAG
    b = s.drag_b if linear else 0.0  # the linearised drag constant only matters for drag law 1
    b_s = s.structure_drag_b if linear else 0.0  # the structure's, likewise (0 when off)
    mass = s.structure_mass  # m + m_a: m when the added mass is off
    zeta = _ratio(s.structure_c + b_s, 2.0 * math.sqrt(s.structure_k * mass))
    zeta_together = _ratio(s.structure_c + b + b_s,
                           2.0 * math.sqrt(s.structure_k * (mass + s.ice_M)))
    added = s.added_mass > 0.0
    morison = [
        ("fluid.rho * structure.Ca * structure.V", s.added_mass,
         "the added mass m_a (kg) finite", False),
        ("fluid.rho * structure.Cd * structure.A / 2", s.structure_drag_B,
         "the structure's drag constant B_s (kg/m) finite", False),
        ("B_s / (structure.m + m_a)", s.structure_drag_B / mass,
         "the structure's drag rate B_s/(m + m_a) (1/m) finite", False),
        ("B_s * drag.v_lin / (structure.m + m_a)", b_s / mass,
         "the structure's drag rate b_s/(m + m_a) (1/s) finite", False),
    ] if s.morison_on else []
    checks = [
        *morison,
        ("structure.k / structure.m" if not added else "structure.k / (structure.m + m_a)",
         s.structure_k / mass, "omega_n^2 = k/m (1/s^2) finite and > 0" if not added else
         "omega_n^2 = k/(m + m_a) (1/s^2) finite and > 0", True),
        ("structure.c / structure.m", s.structure_c / s.structure_m, "c/m (1/s) finite", False),
        ("fluid.rho * ice.Cd * ice.A / 2", s.drag_B, "the drag constant B (kg/m) finite", False),
        ("B / ice.M", s.drag_B / s.ice_M, "the drag rate B/M (1/m) finite", False),
        ("B * drag.v_lin / ice.M", b / s.ice_M, "the drag rate b/M (1/s) finite", False),
        ("zeta^2 = (structure.c / (2 sqrt(k m)))^2", zeta * zeta,
         "the squared damping ratio of the structure finite", False),
        ("zeta^2 = ((structure.c + b) / (2 sqrt(k (m + M))))^2 (bodies in contact)",
         zeta_together * zeta_together,
         "the squared damping ratio of the bodies moving together finite", False),
        ("structure.k * structure.x0^2 / 2", 0.5 * s.structure_k * s.structure_x0 * s.structure_x0,
         "the initial strain energy (J) finite", False),
        ("structure.m * structure.v0^2 / 2", 0.5 * mass * s.structure_v0 * s.structure_v0,
         "the initial kinetic energy of the structure (J) finite", False),
        ("ice.M * ice.v0^2 / 2", 0.5 * s.ice_M * s.ice_v0 * s.ice_v0,
         "the initial kinetic energy of the ice (J) finite", False),
    ]
    for name, value, allowed, positive in checks:
        if not math.isfinite(value) or (positive and value <= 0.0):
            raise ParameterError(name, value, f"{allowed}: {OVERFLOW}")


def _ratio(a: float, b: float) -> float:
    """a / b, inf where b underflowed to 0 (the scale is then out of double precision)."""
    return a / b if b != 0.0 else (math.inf if a != 0.0 else 0.0)


def _check_morison(scene: Scene) -> None:
    """Combinations the Morison loads on the structure do not support
    (docs/explanation/morison.md)."""
    s = scene
    if s.external and s.morison_on:
        name, value = (("structure.Ca", s.structure_Ca) if s.added_mass != 0.0
                       else ("structure.Cd", s.structure_Cd))
        raise ParameterError(name, value, "0 with structure.model = 2: the external structure's "
                             "fluid loads (added mass, drag) belong to the FMU that models it")
    if (s.solver_method == METHOD_FIXED_STEP and s.drag_model == QUADRATIC_DRAG
            and s.structure_drag_on):
        raise ParameterError("structure.Cd", s.structure_Cd,
                             "0 (or structure.A = 0) with drag.model = 2 and solver.method = 2: "
                             "the article's fixed-step scheme keeps the structure in closed "
                             "form, and the quadratic drag on it has none; use solver.method = "
                             "1 or 3, or drag.model = 1")


def validate(scene: Scene) -> None:
    """Raise :class:`ParameterError` for the first parameter outside its allowed range, then for
    combinations whose derived scales overflow (see :func:`_check_scales`)."""
    for spec in PARAMETERS:
        _hold(scene, spec.field, _check_number(spec, getattr(scene, spec.field)))
    _hold(scene, FLOW_INPUT.field, validate_flow(scene.flow_u))
    for spec in STRUCTURE_INPUTS + MODE_LOAD_INPUTS:
        _hold(scene, spec.field, _check_number(spec, getattr(scene, spec.field)))
    if scene.external and scene.solver_method != METHOD_EXACT:
        raise ParameterError("structure.model", scene.structure_model,
                             f"1 with solver.method = {scene.solver_method}: the external "
                             "structure (structure.model = 2) needs solver.method = 1 (exact)")
    if scene.modal:
        _check_modes(scene)
    else:
        _check_morison(scene)
    if scene.ice_z0 > scene.structure_x0 and not scene.external and not scene.modal:
        raise ParameterError("ice.z0", scene.ice_z0,
                             f"<= structure.x0 = {scene.structure_x0!r} (the ice starts upstream)")
    _check_scales(scene)
    check_work(scene)
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
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError("scene file", str(path), f"a TOML file ({exc})") from None
    except FileNotFoundError:
        raise
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError("scene file", str(path), f"a readable TOML file ({exc})") from None
    except ValueError as exc:  # tomllib: an integer of more than 4300 digits
        raise ParameterError("scene file", str(path), f"a TOML file with numbers Python can "
                             f"read ({value_text(str(exc))})") from None

    def twice(name: str, first: str, first_value: Any, how: str, value: Any) -> Exception:
        return ParameterError(name, value, f"given once: the scene file gives it twice, as "
                              f"{first} = {first_value!r} and as {how} = {value!r}")

    return Scene.from_fmi(flatten_table(data, twice))


def flatten_table(table: dict[str, Any],
                  twice: Callable[[str, str, Any, str, Any], Exception]) -> dict[str, Any]:
    """A TOML document's values by their FMI names: ``[ice] M = 800.0`` and ``"ice.M" = 800.0``
    both give ``{"ice.M": 800.0}``. A name given in two spellings raises ``twice(name, first
    spelling, its value, second spelling, its value)``."""
    flat: dict[str, Any] = {}
    spelled: dict[str, str] = {}

    def walk(prefix: str, table: dict[str, Any], spelling: str) -> None:
        for key, value in table.items():
            name = f"{prefix}.{key}" if prefix else key
            how = f"{spelling}{key!r}" if not spelling else f"{spelling} {key!r}"
            if isinstance(value, dict):
                walk(name, value, f"[{name}]" if not spelling else f"{spelling}.{key}")
            elif name in flat:
                raise twice(name, spelled[name], flat[name], how, value)
            else:
                flat[name] = value
                spelled[name] = how

    walk("", table, "")
    return flat
