"""Named scenes that tests of several modules share (keyword arguments of `iceimpact.Scene`)."""

from __future__ import annotations

#: An elastic chatter at a stiff structure (omega_n 1e4 rad/s, a 1.4 kg ice, e = 1, linear
#: drag): many real impacts, bounded by the chatter time (the random search's seed-41 kind).
ELASTIC_CHATTER = dict(structure_m=0.07943282347242814, structure_c=0.0,
                       structure_k=0.07943282347242814 * 1e8, structure_x0=0.0,
                       structure_v0=-0.7529424520614745, ice_M=1.3693257416386013,
                       ice_A=1.784651848737171, ice_Cd=1.3957926554732534, ice_z0=0.0,
                       ice_v0=-0.7529424520614745, impact_e=1.0, drag_model=1,
                       drag_v_lin=1.0, solver_method=1)


def toggled_flow(i: int) -> float:
    """The flow speed at communication step i of a turning flow: +0.1 m/s, reversed one step in
    four (m/s)."""
    return -0.1 if i % 4 == 3 else 0.1


#: The random search's seed-49 scene (method 1, docs/explanation/robustness/stiff-structures.md):
#: a plastic ice pressed by its linear drag on a stiff undamped structure, moving together at
#: 1e-4 m/s at the start.
SEED_49 = dict(structure_m=1851.183822340676, structure_c=0.0, structure_k=5.307267671675244e17,
               structure_x0=-1.0553886196597527e-48, structure_v0=0.0001,
               ice_M=600.1787218082427, ice_A=5.856127714135108, ice_Cd=0.5255924056645146,
               ice_z0=-1.0553886196597527e-48, ice_v0=0.0001, impact_e=0.0, drag_model=1,
               drag_v_lin=0.3242134652243039, solver_method=1)

#: The article's explicit Euler step (method 2, quadratic drag) with a step too long once struck:
#: stable at the start (ice at rest), not once struck at 3 m/s.
EULER_DIVERGES_AFTER_IMPACT = {
    "structure_m": 4.0, "structure_k": 4.0, "structure_v0": -3.0, "ice_M": 0.06, "ice_A": 6.0,
    "ice_Cd": 1.3, "ice_z0": -1e-3, "ice_v0": 0.0, "drag_model": 2, "flow_u": 0.0,
    "solver_method": 2, "solver_detection": 2}
