"""The package carries its own data: every reference file the code reads is package data, and an
installed wheel validates from any folder with nothing beside it."""

import fnmatch
import json
import os
import subprocess
import sys
import sysconfig
from importlib import resources
from pathlib import Path

import pytest

from erosim import data

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[3]


def test_every_reference_file_is_package_data():
    globs = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["erosim"]
    shipped = resources.files("erosim.data").joinpath("reference")
    for name in (*data.REFERENCE_FILES, "README.md"):
        rel = f"data/reference/{name}"
        assert any(fnmatch.fnmatch(rel, g) for g in globs), f"{rel} is not matched by package-data {globs}"
        assert shipped.joinpath(name).is_file(), name
    readme = shipped.joinpath("README.md").read_text(encoding="utf-8")
    for name in data.REFERENCE_FILES:
        assert name in readme  # each file's source and units are documented


def test_reference_csv_reads_columns_and_names_a_missing_file():
    ref = data.reference_csv(data.MARTIN_MOYCE_SURGE)
    assert ref["T"].dtype.kind == "f" and len(ref["T"]) == len(ref["Z"]) >= 13
    with pytest.raises(Exception, match="not in the installed erosim package"):
        data.reference_text("nope.csv")


@pytest.mark.slow
def test_installed_wheel_validates_from_an_empty_folder(tmp_path):
    """Build a wheel, install it alone into a fresh venv (its dependencies from the test's own
    environment through PYTHONPATH, which does not run the editable install's .pth), then run the
    coarse Martin & Moyce validation from a folder with nothing beside it."""
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(REPO)], check=True)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", *map(str, wheels.glob("*.whl"))], check=True)
    env = {**os.environ, "PYTHONPATH": sysconfig.get_paths()["purelib"]}
    work = tmp_path / "empty"
    work.mkdir()
    where = subprocess.run([str(py), "-c", "import erosim; print(erosim.__file__)"], cwd=work, env=env,
                           capture_output=True, text=True, check=True).stdout  # fmt: skip
    assert str(venv) in where and str(REPO) not in where
    run = subprocess.run(
        [str(venv / "bin" / "erosim"), "--quiet", "validate", "martin-moyce", "--resolution", "coarse", "--json",
         "--out", "v"], cwd=work, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["passed"] and result["value"] < 0.10
    assert (work / "v" / "figures" / "front_vs_experiment.png").is_file()
