"""Units wherever a number leaves gaz: the --json summary names the unit of each dimensioned
value (a pressure is a force per wall measure L^(D-1): N in 1D, N/m in 2D, Pa in 3D)."""

from __future__ import annotations

import json

import pytest

from cli_helpers import invoke
from gaz_cli.constants import K_B


@pytest.mark.parametrize("dim,unit", [(1, "N"), (2, "N/m"), (3, "Pa")])
def test_json_summary_names_each_unit(dim, unit):
    """pressure_unit follows the dimension, and the pressure is of that unit: within a factor
    of two of the ideal gas's N k_B T / L^D (a dilute gas, seconds of flight between walls)."""
    res = invoke(["simulate", "--dim", str(dim), "--species", "Ar:10", "--length", "1e-6", "--duration", "1e-8",
                  "--temperature", "300", "--seed", "2", "--no-db", "--json"])
    assert res.exit_code == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary["pressure_unit"] == unit
    assert (summary["length_unit"], summary["duration_unit"], summary["kinetic_energy_unit"]) == ("m", "s", "J")
    ideal = 10 * K_B * 300 / 1e-6 ** dim
    assert 0.5 * ideal < summary["pressure"] < 2 * ideal, (summary["pressure"], ideal)


def test_text_summary_prints_the_same_unit():
    res = invoke(["simulate", "--dim", "2", "--species", "Ar:10", "--length", "1e-6", "--duration", "1e-8",
                  "--seed", "2", "--no-db"])
    assert res.exit_code == 0, res.stderr
    assert " N/m (mean over the walls)" in res.stdout, res.stdout
