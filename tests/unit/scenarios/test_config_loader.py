"""Parameter sections, scenario loading, overrides, presets and their error messages."""

from __future__ import annotations

from pathlib import Path

import pytest

from erosim.core.config import Section, describe_section, param, validate_section
from erosim.core.errors import ConfigError
from erosim.scenarios import kinds, loader


class Inner(Section):
    friction: float = param(0.1, ge=0, le=1, unit="1", doc="velocity damping")
    steps: int = param(10, gt=0, unit="1", doc="steps per cycle")


class Toy(Section):
    seed: int = param(1, doc="random seed")
    inner: Inner = Inner()
    label: str = param("x", doc="a name")


@pytest.fixture
def toy_kind(monkeypatch, tmp_path):
    monkeypatch.setitem(kinds.KINDS, "toy", kinds.Kind(f"{__name__}:Toy", f"{__name__}:Toy"))
    path = tmp_path / "toy.toml"
    path.write_text(
        'schema_version = 1\nkind = "toy"\nname = "toy"\ndescription = "A toy."\n'
        "[inner]\nfriction = 0.2\n[presets.sticky.inner]\nfriction = 0.9\n"
    )
    return path


def test_unknown_key_suggests_nearest():
    with pytest.raises(ConfigError, match=r"Unknown setting 'inner.fricton': did you mean 'friction'\?"):
        validate_section(Toy, {"inner": {"fricton": 0.3}})


def test_out_of_range_names_key_value_and_range():
    with pytest.raises(ConfigError) as err:
        validate_section(Toy, {"inner": {"friction": 1.5}})
    msg = str(err.value)
    assert "inner.friction" in msg and "1.5" in msg and "<= 1" in msg


def test_wrong_type_is_one_sentence():
    with pytest.raises(ConfigError, match="inner.steps"):
        validate_section(Toy, {"inner": {"steps": "many"}})


def test_describe_lists_nested_keys_with_units():
    rows = {r[0]: r for r in describe_section(Toy)}
    assert rows["inner.friction"][2] == "1" and rows["inner.friction"][3] == "velocity damping"


def test_load_precedence_file_preset_set(toy_kind):
    assert loader.load(toy_kind).config.inner.friction == 0.2
    assert loader.load(toy_kind, preset="sticky").config.inner.friction == 0.9
    sc = loader.load(toy_kind, ["preset=sticky", "inner.friction=0.5", "label=dem.tif"])
    assert sc.config.inner.friction == 0.5 and sc.preset == "sticky"
    assert sc.config.label == "dem.tif"  # bare strings need no quotes


def test_resolved_toml_round_trips(toy_kind, tmp_path):
    sc = loader.load(toy_kind, ["inner.steps=3"], preset="sticky")
    again = tmp_path / "scenario.toml"
    again.write_text(sc.to_toml())
    sc2 = loader.load(again)
    assert sc2.config == sc.config and sc2.kind == "toy"
    assert sc2.preset == "sticky"  # by name (its values are already in), so a resumed run reports it too


@pytest.mark.parametrize(
    "text, match",
    [
        ('kind = "toy"\n[inner\n', "not valid TOML"),
        ('kind = "nope"\n', "Unknown scenario kind 'nope'"),
        ("name = 'x'\n", "has no 'kind'"),
        ('schema_version = 7\nkind = "toy"\n', "schema_version 7"),
    ],
)
def test_bad_files(toy_kind, tmp_path, text, match):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(ConfigError, match=match):
        loader.load(bad)


def test_bad_override_and_unknown_preset(toy_kind):
    with pytest.raises(ConfigError, match="key.sub=value"):
        loader.load(toy_kind, ["inner.friction"])
    with pytest.raises(ConfigError, match="no preset 'slick'; its presets: sticky"):
        loader.load(toy_kind, preset="slick")


def test_unknown_scenario_name_suggests():
    with pytest.raises(ConfigError, match="No scenario named"):
        loader.load("surely-not-a-scenario")


def test_a_name_both_in_the_library_and_here_is_refused_as_ambiguous(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "overtopping").mkdir()
    (tmp_path / "overtopping" / "scenario.toml").write_text('kind = "voxel"\n')
    with pytest.raises(ConfigError, match=r"names both a library scenario and the path 'overtopping'"):
        loader.find("overtopping")
    assert loader.find("./overtopping") == Path("./overtopping/scenario.toml")  # the folder, written as a path
    assert loader.find("hydrostatic") == loader.LIBRARY / "hydrostatic.toml"  # no such folder here: the library's


def test_a_users_dem_keeps_its_cell_size_unless_one_is_set():
    """A library scenario's terrain.cell_size describes its generated terrain; --set terrain.file=DEM
    without --set terrain.cell_size runs at the DEM's own cell size."""
    from erosim.scenarios import loader

    assert loader.load("rain-erosion").config.terrain.cell_size == 2.0
    assert loader.load("rain-erosion", ["terrain.file=dem.tif"]).config.terrain.cell_size is None
    seed_preset = loader.load("hydrology", ["terrain.file=dem.tif"], preset="simplehydrology-2020")
    assert seed_preset.config.terrain.cell_size is None  # a preset's generated cell size too
    kept = loader.load("rain-erosion", ["terrain.file=dem.tif", "terrain.cell_size=4.0"]).config.terrain.cell_size
    assert kept == 4.0
