"""Shared test set-up: keep runs out of the working tree and progress bars off; small run folders."""

import json

import numpy as np
import pytest


@pytest.fixture
def cli_runner():
    from click.testing import CliRunner

    return CliRunner()


def _make_run(folder, kind="hydrology", ny=24, nx=31, cell=2.5, seed=0, extra=None):
    """A small run folder as `erosim run` leaves it (report.json with the kind, maps/*.tif); returns the
    height as read back and the other maps."""
    from erosim.io import heightmaps

    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:ny, 0:nx]
    z = 50 + 10 * np.sin(xx / 5.0) + 8 * np.cos(yy / 4.0) + rng.random((ny, nx))
    transform = (cell, 0.0, 1000.0, 0.0, -cell, 5000.0)
    hm = heightmaps.Heightmap(z=z, cell_size=cell, transform=transform)
    (folder / "maps").mkdir(parents=True)
    heightmaps.write(folder / "maps" / "height.tif", hm)
    maps = {
        "lake_depth": np.where(z < 45, 45 - z, 0.0),
        "stream": np.clip(rng.random((ny, nx)) - 0.6, 0, 1),
        "erosion": rng.random((ny, nx)) * 0.2,
        "deposition": rng.random((ny, nx)) * 0.3,
        "vegetation": (rng.random((ny, nx)) > 0.7) * 0.5,
        **(extra or {}),
    }
    for name, a in maps.items():
        heightmaps.write(folder / "maps" / f"{name}.tif", a, like=hm)
    (folder / "report.json").write_text(json.dumps({"kind": kind, "status": "completed"}))
    return np.asarray(heightmaps.read(folder / "maps" / "height.tif").z), maps


@pytest.fixture
def make_run():
    return _make_run
