"""Water at rest in a voxel tank (a vertical wall, a 45° wall and a spherical bowl), every wall the voxel
field through the wall weights (issue 10, `erosim validate voxel-at-rest`)."""

import json

import pytest

from erosim.validation import voxel_at_rest as var


@pytest.mark.slow  # 150 s (load average 9) to 453 s (load average 17) on the shared 2-core machine
def test_coarse_voxel_tank_at_rest(tmp_path):
    """Δx = 2 cm (822 particles), 1.5 s of settling, heads averaged over the last 0.3 s, the start consistent
    with the walls (``hydrostatic-consistent``): the issue's three bounds hold — the pressure's RMS against
    hydrostatic below 3 % of ρ₀gH (measured 2.73 %, 2026-11-26; 6.2 % with the plain hydrostatic start and the
    old fill, which left the concave edges' rows empty; docs/voxel.md), density within 1 % of ρ₀ next to the
    walls (measured 0.39 %; a missing wall term leaves about half of ρ₀ there) and no particle inside the
    solid after any step. The run is deterministic (one thread below 5 000 particles), so the 3 % bound is
    the target itself, not a margin over noise."""
    result = var.run("coarse", tmp_path / "v", progress=False)
    saved = json.loads((tmp_path / "v" / "validation.json").read_text())
    assert saved["value"] == result["value"]
    assert (tmp_path / "v" / "pressure.png").is_file()
    assert result["initial_pressure"] == "hydrostatic-consistent"
    assert result["boundary_particles"] == 0 and result["near_wall_particles"] > result["fluid_particles"] // 2
    assert result["near_wall_density_dev"] < var.RHO_THRESHOLD
    assert result["particles_inside_max"] == 0
    assert result["pressure_rms_rel"] < var.P_THRESHOLD
    assert result["passed"]


@pytest.mark.slow  # 115–140 s on the shared 2-core machine
def test_a_tank_whose_walls_lie_off_the_nodes(tmp_path, monkeypatch):
    """The default resolution (Δx = 1 cm, 2 s) with the grid started 8⅔ cm outside the walls, so that they lie
    2/3 of a cell off the nodes and a node sits Δx/3 from both walls of every floor edge (the fine
    resolution's geometry, at the default's cost). Where the cell polynomial's gradient went flat there, the
    wall vanished in a pocket that drew particles in: 8.85 % RMS; with the gradient blended towards the
    nodes' central differences 1.60 % (erosim.kernels.voxel; docs/voxel.md). Bounds: the issue's three."""
    from functools import partial

    monkeypatch.setattr(var, "tank", partial(var.tank, pad=0.26 / 3))
    result = var.run("default", tmp_path / "v", progress=False)
    assert result["pressure_rms_rel"] < var.P_THRESHOLD
    assert result["near_wall_density_dev"] < var.RHO_THRESHOLD
    assert result["particles_inside_max"] == 0


def test_the_tank_has_its_walls():
    """The solid of the case: the wall distance (positive in the water) at points 1 cm from the bowl's bottom,
    the 45° wall, the vertical wall x = 0 and the floor, to within the field's error on curved or tilted
    surfaces (1 mm on 1 cm voxels, docs/voxel.md), and the CLI knows the case."""
    import numpy as np

    from erosim.cli import VALIDATION_CASES

    vt = var.tank(0.01)
    s = np.sqrt(0.5)
    pts = np.array(
        [
            [var.XB, 0.5 * var.W, -var.SINK + 0.01],  # above the bowl's bottom
            [var.X45 + 0.05 - 0.01 * s, 0.5 * var.W, 0.05 + 0.01 * s],  # off the 45° wall
            [0.01, 0.5 * var.W, 0.12],  # off the wall x = 0
            [var.XB + var.R + 0.02, 0.5 * var.W, 0.01],  # over the floor between the bowl and the slope
        ]
    )
    l, _ = vt.distance(pts)
    assert np.allclose(l, 0.01, atol=1e-3), l
    assert "voxel-at-rest" in VALIDATION_CASES


def test_the_start_is_chosen_for_voxel_at_rest_only():
    """``--start`` picks the voxel-at-rest case's start; given to another case it is refused in one sentence."""
    from click.testing import CliRunner

    from erosim.cli import cli

    res = CliRunner().invoke(cli, ["validate", "hydrostatic", "--start", "hydrostatic", "--json"])
    assert res.exit_code != 0
    assert "--start applies to voxel-at-rest only, not 'hydrostatic'" in res.output
    res = CliRunner().invoke(cli, ["validate", "voxel-at-rest", "--start", "no-such-start"])
    assert res.exit_code == 2 and "hydrostatic-consistent" in res.output
