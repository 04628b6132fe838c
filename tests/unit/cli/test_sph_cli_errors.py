"""Bad SPH scenario input → one clear sentence and a non-zero exit, without a traceback (issue 2, item 8)."""

from pathlib import Path

import pytest
from click.testing import CliRunner

from erosim.cli import cli

LIB = Path(__file__).resolve().parents[3] / "src" / "erosim" / "scenarios" / "library"


def _run(args):
    result = CliRunner().invoke(cli, ["--quiet", *args])
    return result.exit_code, result.output  # click ≥ 8.2: stdout and stderr interleaved


def _one_sentence(text: str) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, f"expected one line, got: {text!r}"
    assert "Traceback" not in text
    assert lines[0].startswith("erosim: error: ")
    return lines[0]


def _write(tmp_path, text: str) -> Path:
    p = tmp_path / "case.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_malformed_toml(tmp_path):
    bad = _write(tmp_path, (LIB / "hydrostatic.toml").read_text().replace("[run]", "[run"))
    code, out = _run(["run", str(bad), "--out", str(tmp_path / "o")])
    assert code != 0
    line = _one_sentence(out)
    assert "not valid TOML" in line and "case.toml" in line


def test_unknown_key_suggests_nearest(tmp_path):
    code, out = _run(["run", "hydrostatic", "--set", "run.t_ned=0.1", "--out", str(tmp_path / "o")])
    assert code != 0
    line = _one_sentence(out)
    assert "run.t_ned" in line and "t_end" in line


def test_unknown_key_in_file_sph_table(tmp_path):
    text = (LIB / "hydrostatic.toml").read_text().replace("[sph]\n", '[sph]\nviscousity = "laminar"\n')
    code, out = _run(["run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")])
    assert code != 0
    line = _one_sentence(out)
    assert "sph.viscousity" in line and "'viscosity'" in line


@pytest.mark.parametrize(
    "override, key",
    [
        ("sph.spacing=-0.01", "sph.spacing"),
        ("run.t_end=0", "run.t_end"),
        ("sph.alpha=5", "sph.alpha"),
        ('sph.eos="ideal-gas"', "sph.eos"),
    ],
)
def test_value_out_of_range(tmp_path, override, key):
    code, out = _run(["run", "dam-break-2d", "--set", override, "--out", str(tmp_path / "o")])
    assert code != 0
    line = _one_sentence(out)
    assert key in line


def test_fluid_block_outside_domain(tmp_path):
    text = (LIB / "dam-break-2d.toml").read_text().replace("hi = [0.05715, 0.1143]", "hi = [0.05715, 0.3]")
    code, out = _run(["run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")])
    assert code != 0
    line = _one_sentence(out)
    assert "fluid block 1" in line and "outside the domain" in line


def test_bad_input_leaves_no_run_folder(tmp_path):
    code, _ = _run(["run", "hydrostatic", "--set", "run.t_end=-1", "--out", str(tmp_path / "o")])
    assert code != 0
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "scenario, override, key",
    [
        ("dam-break-2d", "run.t_end=inf", "run.t_end"),  # was accepted ("inf h"): the progress bar crashed
        ("dam-break-2d", "sph.spacing=inf", "sph.spacing"),
        ("dam-break-2d", "run.t_end=nan", "run.t_end"),
        ("rain-erosion", "sph.spacing=-inf", "sph.spacing"),
        ("flood", "flood.manning=nan", "flood.manning"),
    ],
)
def test_non_finite_settings_are_one_sentence_before_the_run(tmp_path, scenario, override, key):
    """Every float setting refuses NaN and ±inf (the common schema), exit 2, no folder."""
    code, out = _run(["run", scenario, "--set", override, "--out", str(tmp_path / "o")])
    line = _one_sentence(out)
    assert code == 2 and key in line and "finite" in line
    assert not (tmp_path / "o").exists()


def test_dem_heights_beyond_any_terrain_are_refused_before_the_run(tmp_path):
    """An undeclared nodata value (1e30) broke height.png after the whole run: now one sentence naming
    the file and the fix, before anything runs."""
    import numpy as np

    z = np.full((24, 24), 100.0)
    z[3:6, 3:6] = 1e30
    dem = tmp_path / "dem.npy"
    np.save(dem, z)
    code, out = _run(["run", "hydrology", "--set", f"terrain.file={dem}", "--out", str(tmp_path / "o")])
    line = _one_sentence(out)
    assert code == 2 and "dem.npy" in line and "1e+30" in line and "nodata" in line
    assert not (tmp_path / "o").exists()


def test_a_truncated_checkpoint_on_resume_is_one_sentence(tmp_path):
    """--resume of a folder whose checkpoint was cut short: damaged, and what to do (was BadZipFile)."""
    out = tmp_path / "o"
    code, text = _run(["run", "hydrology", "--set", "terrain.size=32", "--set", "run.cycles=2", "--set",
                       "run.frames=0", "--out", str(out)])  # fmt: skip
    assert code == 0, text
    ck = next((out / "checkpoint").glob("*.npz"))
    ck.write_bytes(ck.read_bytes()[: ck.stat().st_size // 2])
    (out / "report.json").write_text('{"status": "interrupted"}')  # so that --resume reads the checkpoint
    code, text = _run(["run", "--resume", str(out)])
    line = _one_sentence(text)
    assert code == 2 and "is damaged" in line and "start it again" in line
