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
