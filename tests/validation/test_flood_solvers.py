"""The two flood solvers on one small valley breach agree on the flooded extent (issue 9, item 7)."""

import json

import pytest

from erosim.validation import flood_solvers


@pytest.mark.slow
def test_coarse_solvers_agree_on_the_flooded_extent(tmp_path):
    """Coarse: 2.5 m shallow-water particles against 1.0 m 3-D ones (26 s on 2 cores with the kernels
    compiled, at a load of 3.5; four minutes under a load of 10), so marked slow.
    Measured IoU 0.88 (default resolution: see docs/flood.md); the issue's bound is 0.8. The extent
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
