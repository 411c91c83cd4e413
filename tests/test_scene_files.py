"""Fuzzing of the scene files (TOML): outside data, refused field by field, never a crash."""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from iceimpact import ParameterError, load_scene

# --- fuzz: scene files ----------------------------------------------------------------------------

VALID_TOML = b"""\
"impact.e" = 0.5
[structure]
m = 1600.0
k = 1.0e6
c = 200.0
[ice]
M = 800.0
z0 = -0.01
[flow]
u = 0.1
"""


def _load_bytes(tmp_path, data: bytes):
    path = tmp_path / "scene.toml"
    path.write_bytes(data)
    return load_scene(path)


def _only_parameter_errors(tmp_path, data: bytes) -> None:
    try:
        _load_bytes(tmp_path, data)
    except ParameterError as exc:
        text = str(exc)
        assert " is not allowed: " in text and len(text) < 2000, text
    # any other exception fails the test


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=300))
def test_scene_file_random_bytes(tmp_path, data):
    _only_parameter_errors(tmp_path, data)


def test_scene_file_truncated_and_bit_flipped(tmp_path):
    assert _load_bytes(tmp_path, VALID_TOML).ice_M == 800.0
    for n in range(len(VALID_TOML)):
        _only_parameter_errors(tmp_path, VALID_TOML[:n])
    rng = random.Random(12)
    for _ in range(300):
        data = bytearray(VALID_TOML)
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(data))
            data[i] ^= 1 << rng.randrange(8)
        _only_parameter_errors(tmp_path, bytes(data))


@pytest.mark.parametrize("text, name", [
    ('"structure.k" = 1e400', "structure.k"),                # TOML overflow: inf in the file
    ('"structure.k" = ' + "9" * 5000, "scene file"),          # beyond Python's int parsing
    ('"structure.k" = ' + "9" * 400, "structure.k"),          # an integer no double holds
    ('"ice.M" = 1e308\n"ice.v0" = 1e300', "ice.M * ice.v0^2 / 2"),
    ('"structure.k" = 1e40', "sqrt(structure.k / structure.m)"),
    ('"flow.u" = 1e12\n"drag.model" = 2',
     "|flow.u| + |ice.v0| + 2 sqrt(structure.v0^2 + (omega_n structure.x0)^2)"),
    ('"ice.M" = 1.0\n"ice.M" = 2.0', "scene file"),           # duplicate key: TOML error
    ('"ice.M" = 1.0\n[ice]\nM = 2.0', "ice.M"),               # twice, two spellings
    ('"ice.M" = "heavy"', "ice.M"),
    ('"ice.M" = true', "ice.M"),
    ('"ice.M" = [1.0]', "ice.M"),
    ('"ice.M" = 1979-05-27', "ice.M"),
    ('"ice.M" = nan', "ice.M"),
    ('"ice.M" = -inf', "ice.M"),
    ('"drag.model" = 1.5', "drag.model"),
    ('"solver.method" = 99999999999999999999999', "solver.method"),
    ("[ice]\nM = { a = 1 }", "ice.M.a"),
    ('"ice.mass" = 1.0', "ice.mass"),
    ("[solver]\nchatter_fraction = 0.7", "solver.chatter_fraction"),  # above 0.5
])
def test_scene_file_bad_values(tmp_path, text, name):
    with pytest.raises(ParameterError) as info:
        _load_bytes(tmp_path, text.encode())
    assert info.value.name == name
    assert " is not allowed: " in str(info.value) and len(str(info.value)) < 2000


def test_scene_file_sets_the_chatter_fraction(tmp_path):
    """solver.chatter_fraction read from a scene file, in either spelling, as any parameter."""
    assert _load_bytes(tmp_path, b"[solver]\nchatter_fraction = 1e-3\n").solver_chatter_fraction \
        == 1e-3
    assert _load_bytes(tmp_path, b'"solver.chatter_fraction" = 0.5\n').solver_chatter_fraction \
        == 0.5
