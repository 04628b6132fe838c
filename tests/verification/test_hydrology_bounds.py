"""Nothing is read or written outside the map, on any edge (HY-8: "never read/write outside").

The droplet (general, seed-case and batch), lake and cycle kernels run in a subprocess with Numba's bounds checking on
(``NUMBA_BOUNDSCHECK=1``, a separate cache), so any out-of-range index raises IndexError. Terrains
tilted toward each edge and a bowl whose lakes reach the edges make the droplets and lakes work
right at the borders. Slow: the bounds-checked build compiles from scratch (~1 min).
"""

import os
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from erosim.hydrology.model import HydrologyModel
    from erosim.hydrology.params import HydrologyParams, VegetationParams
    from erosim.core.heightmap import Heightmap
    n = 40
    yy, xx = np.mgrid[0:n, 0:n].astype(float)
    rng = np.random.default_rng(0)
    terrains = [8.0 * yy, 8.0 * (n - 1 - yy), 8.0 * xx, 8.0 * (n - 1 - xx),
                -3.0 * np.hypot(xx - n / 2, yy - n / 2) + 5.0 * rng.random((n, n))]
    for i, z in enumerate(terrains):
        for sea in (None, 20.0):
            for ell, dx, nb in ((40.0, 20.0, 0), (0.0, 20.0, 0), (0.0, 20.0, 16), (40.0, 20.0, 16)):
                p = HydrologyParams(length_scale=ell, cycle_droplets=20000, sea_level=sea,
                                    max_step=1.0 if ell else 0.0, batch=nb)
                m = HydrologyModel(Heightmap(z=z + rng.random((n, n)), cell_size=dx), p,
                                   VegetationParams(spawn=100.0), seed=i)
                m.run(5)
                assert m.water_budget()["closure_rel"] < 1e-9
                assert m.sediment_budget()["closure_rel"] < 1e-9
    print("ok")
    """
)


# In the default run (about 30 s of compiling with bounds checks): issue 3 asks that nothing is
# read or written outside the map on any edge, and only a bounds-checked build can show it.
@pytest.mark.slow  # every kernel on bounds-checked compiles, about 30 s
def test_kernels_stay_inside_the_map(tmp_path):
    env = dict(os.environ, NUMBA_BOUNDSCHECK="1", NUMBA_CACHE_DIR=str(tmp_path / "nbcache"))
    res = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.strip().endswith("ok")
