"""The two flood solvers on one small valley breach agree on the flooded extent (issue 9, item 7)."""

import json

import pytest

from erosim.validation import flood_solvers


@pytest.mark.slow
def test_coarse_solvers_agree_on_the_flooded_extent(tmp_path):
    """Coarse: 2.5 m shallow-water particles against 1.0 m 3-D ones (26 s on 2 cores with the kernels
    compiled, at a load of 3.5; four minutes under a load of 10), so marked slow.
    Measured IoU 0.90 with both solvers' maps the SPH depth at the cell centres (0.97 when the 3-D maps
    marked each particle's square √(V/D) with its column's depth, 0.89 when both did; the default
    resolution: see docs/flood.md); the issue's bound is 0.8. The extent
    is two or three cells wide below the dam, so one cell either side moves the IoU by about 0.03."""
    out = tmp_path / "v"
    r = flood_solvers.run("coarse", out=out, progress=False)
    assert r["iou"] == r["value"] and r["iou"] >= flood_solvers.THRESHOLD, r
    # the same water: the 3-D lattice holds the set-up's reservoir to within one particle (1 m³)
    assert r["sph3d"]["volume_initial_m3"] == pytest.approx(r["swe"]["volume_initial_m3"], abs=1.0)
    # both floods reach the open north edge within the 40 s
    assert r["swe"]["volume_out_m3"] > 0 and r["sph3d"]["volume_out_m3"] > 0
    assert json.loads((out / "validation.json").read_text())["passed"]
    assert (out / "figures" / "flood_solvers.png").is_file()


def test_the_arrival_map_follows_ritters_front():
    """The arrival-time map of a dam break on a flat, frictionless channel against Ritter's front
    x_f = 2 √(g h₀) t (Ritter 1892): the cells along the channel first get wet at x / (2 √(g h₀)).

    h₀ = 10 m, particles of 1 m (h₀/10) on 1 m cells, splitting at every depth with the daughters' H
    relaxing over half a crossing time (``split_depth = h₀``, ``split_relax = 0.5``), 5 s (the front
    travels 99 m); a few seconds. Without splitting the thin tip is under-resolved and the map is 40–42 %
    late with 38 % of the window dry; with the defaults (split below 1 m = 0.1 h₀ only, relax over five
    crossing times) 17–27 % late with 8 % dry (measured; docs/flood.md, "The gradual split").
    Checked between 0.4 and 0.9 of the reach: nearer the dam the start-up delay (the front
    leaves the lattice over its first steps) is a larger share of a short time, beyond 0.9 the tip is
    thinner than the wet depth. The 10 % tolerance: the map records when the depth first passes
    flood.wet_depth w = 0.01 m, which Ritter's fan reaches at x / (2c₀ − 3√(g w)), 4.7 % after the
    front at h₀ = 10 m, plus the start-up delay (measured −3.3 % … +6.6 % in this window).
    """
    import math

    import numpy as np

    from erosim.analysis.hazard import HazardMaps
    from erosim.sph.shallow_water_vacondio2012 import ShallowWaterParams, ShallowWaterSPH, lattice_volume

    g, h0, dx, t_end = 9.81, 10.0, 1.0, 5.0
    c0 = math.sqrt(g * h0)
    reach = 2.0 * c0 * t_end
    upstream, downstream, width = c0 * t_end + 5 * dx, 1.1 * reach, 4 * dx  # the rarefaction stays inside
    nx, ny = int(round((upstream + downstream) / dx)) + 2, int(round(width / dx)) + 2  # + the wall cells
    dam = 0.5 * dx + upstream
    x, y = (a.ravel() for a in np.meshgrid(np.arange(dx, dam, dx), np.arange(dx, 0.5 * dx + width, dx)))
    prm = ShallowWaterParams(split=True, split_depth=h0, split_relax=0.5)
    vol = lattice_volume(np.full(x.size, h0), dx, prm.support, prm.max_support)
    swe = ShallowWaterSPH(np.zeros((ny, nx)), dx, np.column_stack([x, y]), vol, dx, prm, surface=h0)
    maps = HazardMaps((ny, nx), 0.01)
    swe.update_maxima(maps, maps.wet_depth)  # the reservoir at t = 0, as the flood run's tracker does
    while swe.t < t_end:
        swe.step()
        swe.update_maxima(maps, maps.wet_depth)
    along = np.arange(nx) * dx - dam  # the cells' distance from the dam
    window = (along > 0.4 * reach) & (along < 0.9 * reach)
    arrival = maps.arrival[1:-1, window]  # every row inside the channel's walls
    exact = along[window] / (2.0 * c0)
    assert np.all(np.isfinite(arrival)), "the front has not reached 0.9 of Ritter's reach"
    err = arrival / exact - 1.0
    assert np.abs(err).max() < 0.10, err
