"""Sweep designs and plans: the members a --vary / [sweep] table states, seeded; bad input in one sentence."""

import numpy as np
import pytest

from erosim.core.errors import ConfigError
from erosim.sweep import design
from erosim.sweep.plan import Threshold, build

HYDROLOGY_SMALL = ["terrain.size=16", "run.cycles=2", "run.frames=0"]


def test_grid_is_every_combination_first_key_slowest():
    varies = [design.parse_vary("a.x=1,2"), design.parse_vary("b=0:1:3")]
    got = design.members(varies)
    assert got == [
        {"a.x": 1, "b": 0.0}, {"a.x": 1, "b": 0.5}, {"a.x": 1, "b": 1.0},
        {"a.x": 2, "b": 0.0}, {"a.x": 2, "b": 0.5}, {"a.x": 2, "b": 1.0},
    ]  # fmt: skip


def test_evenly_spaced_whole_numbers_stay_whole():
    assert design.members([design.parse_vary("n=10:40:4")]) == [{"n": 10}, {"n": 20}, {"n": 30}, {"n": 40}]
    assert design.members([design.parse_vary("n=10:40:3")]) == [{"n": 10.0}, {"n": 25.0}, {"n": 40.0}]


def test_listed_values_are_toml():
    v = design.parse_vary('k=1, 2.5, true, "a b", dem.tif')
    assert v.values == (1, 2.5, True, "a b", "dem.tif")


def test_random_draws_are_seeded_per_key_and_in_range():
    a = design.members([design.parse_vary("x=2:3~50")], random_seed=7)
    b = design.members([design.parse_vary("x=2:3~50"), design.parse_vary("y=1,2")], random_seed=7)
    c = design.members([design.parse_vary("x=2:3~50")], random_seed=8)
    xs = [m["x"] for m in a]
    assert all(2.0 <= x < 3.0 for x in xs) and len(set(xs)) == 50
    assert xs == [m["x"] for m in b if m["y"] == 1]  # adding a key does not change x's draws
    assert xs != [m["x"] for m in c]


def test_latin_hypercube_uses_each_level_once_and_one_draw_per_stratum():
    varies = [design.parse_vary("a=1,2,3,4,5"), design.parse_vary("b=0:10~5"), design.parse_vary("c=0:4:5")]
    got = design.members(varies, design="lhs", random_seed=3)
    assert len(got) == 5
    assert sorted(m["a"] for m in got) == [1, 2, 3, 4, 5]
    assert sorted(m["c"] for m in got) == [0, 1, 2, 3, 4]
    strata = sorted(int(m["b"] // 2) for m in got)  # 5 strata of width 2 in [0, 10)
    assert strata == [0, 1, 2, 3, 4]
    assert got == design.members(varies, design="lhs", random_seed=3)
    assert got != design.members(varies, design="lhs", random_seed=4)


def test_seeds_repeat_every_design_point():
    got = design.members([design.parse_vary("a=1,2")], seeds=3, base_seed=10)
    assert got == [{"a": 1, "seed": s} for s in (10, 11, 12)] + [{"a": 2, "seed": s} for s in (10, 11, 12)]


@pytest.mark.parametrize(
    "item, words",
    [
        ("a=1:2:0", "at least 1"),
        ("a=1:2:1.5", "whole number"),
        ("a=3:1:4", "backwards"),
        ("a=x:2:3", "not a number"),
        ("a=1,,2", "empty value"),
        ("a", "KEY=SPEC"),
        (".b=1,2", "names no setting"),
    ],
)
def test_bad_specification_is_one_sentence(item, words):
    with pytest.raises(ConfigError, match=words):
        design.parse_vary(item)


def test_latin_hypercube_needs_equal_sizes():
    with pytest.raises(ConfigError, match="same n"):
        design.members([design.parse_vary("a=1,2"), design.parse_vary("b=0:1:3")], design="lhs")


def test_seed_cannot_be_varied_and_repeated():
    with pytest.raises(ConfigError, match="seed"):
        design.members([design.parse_vary("seed=1,2")], seeds=2)


def test_thresholds_parse_and_name_their_variable():
    t = Threshold.parse("max_water_depth > 0.3")
    assert (t.name, t.op, t.value, t.variable) == ("max_water_depth", ">", 0.3, "p_max_water_depth_gt_0p3")
    assert Threshold.parse("hazard>=5").variable == "p_hazard_ge_5"
    assert t.label("m") == "P(max_water_depth > 0.3 m)"
    for bad in ("erosion", "erosion < 1", "erosion > x", "> 1"):
        with pytest.raises(ConfigError, match="map > value"):
            Threshold.parse(bad)


def test_plan_validates_every_member_before_running():
    plan, base = build("hydrology", HYDROLOGY_SMALL, None, ["hydrology.capacity=0.5,2"], seeds=2, threads=1)
    assert plan.keys == ["hydrology.capacity", "seed"] and len(plan.members) == 4
    assert plan.members[1] == {"hydrology.capacity": 0.5, "seed": 2}  # the library scenario's seed is 1
    assert plan.overrides(3) == ["hydrology.capacity=2", "seed=2"]
    assert "[terrain]" in base and "size = 16" in base
    with pytest.raises(ConfigError, match=r"Sweep member m0001 \(hydrology.capacity=-1\)"):
        build("hydrology", HYDROLOGY_SMALL, None, ["hydrology.capacity=1,-1"], threads=1)
    with pytest.raises(ConfigError, match="hydrology.no_such_key|no_such_key"):
        build("hydrology", HYDROLOGY_SMALL, None, ["hydrology.no_such_key=1,2"], threads=1)


def test_sweep_table_of_a_scenario_file_and_command_line_precedence(tmp_path):
    src = tmp_path / "s.toml"
    from erosim.scenarios.loader import find

    text = find("hydrology").read_text(encoding="utf-8")
    src.write_text(
        text + '\n[sweep]\nvary = { "hydrology.capacity" = "1:3:3", "hydrology.friction" = [0.4, 0.6] }\n'
        'design = "grid"\nexceed = ["erosion > 2"]\n',
        encoding="utf-8",
    )
    plan, _ = build(str(src), HYDROLOGY_SMALL, None, [], threads=1)
    assert len(plan.members) == 6 and plan.exceed == ["erosion > 2"]
    plan, _ = build(str(src), HYDROLOGY_SMALL, None, ["hydrology.friction=0.5"], threads=1)
    assert [m["hydrology.friction"] for m in plan.members] == [0.5, 0.5, 0.5]
    assert np.allclose([m["hydrology.capacity"] for m in plan.members], [1, 2, 3])
    src.write_text(text + "\n[sweep]\nvary = 3\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="sweep"):
        build(str(src), HYDROLOGY_SMALL, None, [], threads=1)


def test_terrain_seed_keeps_one_terrain_while_the_run_seed_varies():
    from erosim.scenarios.schema_common import TerrainSection, build_terrain

    own = TerrainSection(preset="hills", size=24, seed=5)
    assert np.array_equal(build_terrain(own, 1).z, build_terrain(own, 2).z)
    assert np.array_equal(build_terrain(own, 1).z, build_terrain(TerrainSection(preset="hills", size=24), 5).z)
    shared = TerrainSection(preset="hills", size=24)
    assert not np.array_equal(build_terrain(shared, 1).z, build_terrain(shared, 2).z)
