"""Scene parameters: defaults, validation messages, TOML scene files."""

import math

import pytest

from iceimpact import PARAMETERS, ParameterError, Scene, load_scene

# (FMI name, a value outside its range, words the allowed range must mention)
INVALID = [
    ("structure.m", 0.0, "> 0"), ("structure.m", -1.0, "> 0"),
    ("structure.c", -1e-9, ">= 0"),
    ("structure.k", 0.0, "> 0"),
    ("structure.x0", math.inf, "finite"), ("structure.v0", math.nan, "finite"),
    ("ice.M", -5.0, "> 0"), ("ice.A", 0.0, "> 0"), ("ice.Cd", -0.1, ">= 0"),
    ("ice.z0", 0.5, "<= structure.x0"), ("ice.v0", -math.inf, "finite"),
    ("fluid.rho", 0.0, "> 0"),
    ("impact.e", -0.01, "0 <= e <= 1"), ("impact.e", 1.01, "0 <= e <= 1"),
    ("drag.model", 3, "1 or 2"), ("drag.model", 1.5, "integer"),
    ("drag.v_lin", 0.0, "> 0"),
    ("solver.method", 0, "1, 2 or 3"),
    ("solver.dt", -1e-4, ">= 1e-9"), ("solver.dt", 1e-10, ">= 1e-9"),
    ("solver.rtol", 0.0, "1e-13 <= rtol < 1"), ("solver.rtol", 1e-14, "1e-13 <= rtol < 1"),
    ("solver.rtol", 1.0, "1e-13 <= rtol < 1"),
    ("flow.u", math.nan, "finite"),
]


def test_defaults_are_the_figure2_scene():
    s = Scene()
    assert (s.structure_m, s.structure_c, s.structure_k) == (1600.0, 200.0, 1e6)
    assert (s.ice_M, s.ice_A, s.ice_Cd, s.fluid_rho) == (1600.0, 1.0, 1.0, 999.0)
    assert (s.ice_z0, s.ice_v0, s.flow_u, s.impact_e) == (-0.01, 0.01, 0.1, 1.0)
    assert s.drag_b == pytest.approx(49.95)  # eq. 30
    assert s.omega_n == pytest.approx(25.0)


@pytest.mark.parametrize("name,value,allowed", INVALID)
def test_invalid_parameter_names_itself_value_and_range(name, value, allowed):
    with pytest.raises(ParameterError) as err:
        Scene.from_fmi({name: value})
    assert err.value.name == name
    text = str(err.value)
    assert text.startswith(f"{name} = ")
    assert repr(value) in text or str(value) in text
    assert allowed in text


@pytest.mark.parametrize("spec", PARAMETERS, ids=lambda p: p.name)
def test_every_parameter_refuses_nan_and_out_of_range(spec):
    bad = [math.nan, math.inf]
    if spec.minimum is not None:
        bad.append(spec.minimum - 1)
    if spec.maximum is not None:
        bad.append(spec.maximum + 1)
    for value in bad:
        with pytest.raises(ParameterError) as err:
            Scene.from_fmi({spec.name: value})
        assert err.value.name == spec.name


def test_unknown_name_is_an_error():
    with pytest.raises(ParameterError, match="no such parameter"):
        Scene.from_fmi({"ice.mass": 3.0})


def test_boolean_is_not_a_number():
    with pytest.raises(ParameterError):
        Scene(impact_e=True)


def test_fmi_round_trip():
    s = Scene(ice_M=800.0, drag_model=2, flow_u=0.3)
    assert Scene.from_fmi(s.to_fmi()) == s


def test_toml_scene_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text('"impact.e" = 0.5\n[ice]\nM = 800.0\nA = 2.0\n[drag]\nmodel = 2\n'
                    '[flow]\nu = 0.3\n')
    s = load_scene(path)
    assert (s.ice_M, s.ice_A, s.drag_model, s.flow_u, s.impact_e) == (800.0, 2.0, 2, 0.3, 0.5)
    assert s.structure_m == 1600.0


def test_toml_typo_is_an_error(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text("[ice]\nmass = 800.0\n")
    with pytest.raises(ParameterError, match="ice.mass"):
        load_scene(path)
