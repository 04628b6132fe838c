"""The ``voxel`` kind (SPH water scouring a voxel terrain): the overtopping case end to end at a coarse
resolution, its outputs, the budget, ``non_erodible_below``, exact resume and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner
from PIL import Image

from erosim.cli import cli
from erosim.core.errors import Interrupted
from erosim.io.particles import read_pvd, read_vtp
from erosim.io.runfolder import RunFolder
from erosim.scenarios import loader, runner
from erosim.terrain.voxel import VoxelTerrain

# 4 cm particles and voxels (about 150 particles): seconds per run. τ_c is lowered and the settling
# time shortened so that a run of a fraction of a second erodes (the scale of the library presets needs
# the overflow of several seconds).
COARSE = ["sph.spacing=0.04", "voxels.cell_size=0.04", "run.t_end=0.3", "run.output_interval=0.15",
          "run.profile_interval=0.05", "erosion.tau_c=0.5", "erosion.k_eps=2.0", "erosion.start=0.05",
          "erosion.every=10", "erosion.k_eps_units=fraction", "erosion.morfac=1"]  # fmt: skip


def _cli(*args):
    res = CliRunner().invoke(cli, ["--quiet", *args])
    return res.exit_code, res.output


def _sets(items):
    return [a for s in items for a in ("--set", s)]


def test_every_voxel_scenario_has_a_case():
    names = {n for n in loader.library_names() if loader.read_toml(loader.LIBRARY / f"{n}.toml")["kind"] == "voxel"}
    assert names == {"overtopping", "mountain-lake", "canyon-caves"}


def test_mountain_lake_turns_any_dem_into_voxels_and_refuses_one_too_large(tmp_path):
    from erosim.scenarios.voxel.build import build_terrain
    from erosim.scenarios.voxel.outputs import surface_profile

    yy, xx = np.mgrid[0:9, 0:12]
    dem = 2.0 + 0.25 * xx + 0.1 * yy  # a tilted plane, heights in metres, 1 m cells (.npy)
    np.save(tmp_path / "dem.npy", dem)
    dem_file = f"terrain.file={tmp_path / 'dem.npy'}"  # a .npy DEM: 1 m cells
    # on a user's DEM the scene's 0.5 m voxels and particles give way to the DEM's own cell size
    sc = loader.load("mountain-lake", [dem_file])
    assert sc.config.voxels.scale == "dem"
    t = build_terrain(sc.config)
    assert t.shape[1:] == (9, 12) and t.cell_size == 1.0  # 1 m voxels over 8 m x 11 m
    # unless the command line sets either size
    sc = loader.load("mountain-lake", [dem_file, "voxels.cell_size=0.5", "sph.spacing=0.5"])
    assert sc.config.voxels.scale == "set"
    t = build_terrain(sc.config)
    assert t.shape[1:] == (17, 23)  # 0.5 m voxels over 8 m x 11 m
    # the surface along a row is the DEM's plane (row 0 of the map is north: y = 8 m is its first row);
    # exact on a plane to float32 rounding of the ramp, well inside a voxel
    x, z = surface_profile(t, 4.0)
    assert np.allclose(z, 2.0 + 0.25 * x + 0.1 * (8 - 4.0), atol=1e-3)
    # the command, on the DEM alone (shortened): it runs at the DEM's scale
    res = CliRunner().invoke(cli, ["run", "mountain-lake", "--out", str(tmp_path / "dem"), "--set", dem_file,
                                   "--set", "run.t_end=0.5"])  # fmt: skip
    assert res.exit_code == 0, res.output
    # the set-up is announced before it starts and timed when it ends (the estimate's line comes first)
    said = res.stderr.splitlines()
    first = next(i for i, ln in enumerate(said) if "setting up (about" in ln)
    assert "of memory and" in said[first - 1] and said[first + 1].startswith("mountain-lake: set up in ")
    rep = json.loads((tmp_path / "dem" / "report.json").read_text())
    assert rep["resolution"]["spacing"] == 1.0 and rep["voxels"]["cell_size_m"] == 1.0
    assert rep["particles_inside_solid"] == 0
    import rasterio

    maps = tmp_path / "dem" / "maps"
    with rasterio.open(maps / "height.tif") as ds:  # the DEM's grid, north up
        height = ds.read(1)
    # the top surface of the voxels is the DEM's plane to float32 rounding of the ramp (as the profile above)
    assert height.shape == dem.shape and np.allclose(height, dem, atol=1e-3)
    for name in ("height_initial", "erosion", "deposition", "water_depth"):
        assert (maps / f"{name}.tif").is_file()
    assert rep["maps"]["water_depth"]["min"] >= 0.0
    code, text = _cli("run", "mountain-lake", "--out", str(tmp_path / "big"), "--set",
                      f"terrain.file={tmp_path / 'dem.npy'}", "--set", "voxels.max_bytes=2000")  # fmt: skip
    assert code != 0 and "use voxels of at least" in " ".join(text.split()), text
    assert not (tmp_path / "big").exists()


def test_canyon_caves_are_carved_only_under_their_height():
    from erosim.scenarios.voxel.build import build_terrain

    with_caves = build_terrain(loader.load("canyon-caves").config)
    without = build_terrain(loader.load("canyon-caves", ["caves.wavelength=0"]).config)
    below = loader.load("canyon-caves").config.caves.below
    z = with_caves.axes()[2]
    changed = np.any(with_caves.density != without.density, axis=(1, 2))
    assert changed.any()  # caves were carved
    # no node higher than `below` plus the ramp's half-width changed (the intersection's ramp reaches b up)
    assert z[changed].max() <= below + with_caves.band + 1e-9
    assert with_caves.solid_volume() < without.solid_volume()


def test_overtopping_runs_and_writes_its_outputs(tmp_path):
    out = tmp_path / "run"
    code, text = _cli("run", "overtopping", "--preset", "full", "--out", str(out),
                      *_sets(COARSE + ['run.meshes=["obj", "ply", "glb"]']))  # fmt: skip
    assert code == 0, text
    rep = json.loads((out / "report.json").read_text())
    # the shear of the settling and inflowing water at τ_c = 0.5 erodes within 0.3 s
    assert rep["eroded_volume_m3"] > 0
    fe = rep["first_erosion"]
    assert fe["t"] >= 0.05  # nothing before erosion.start
    assert set(fe) >= {"t", "x", "z"}
    b = rep["budget"]
    # the eroder's removed volume is the field's loss: float32 differences summed in float64
    assert b["carried_off"] == pytest.approx(b["eroded"], rel=1e-12)
    assert b["closure_rel"] < 1e-9
    assert rep["particles_inside_solid"] == 0
    assert rep["timings"]["particle_steps_per_s"] > 0
    w = rep["water"]
    water_m3 = (w["initial_particles"] + sum(w["added"].values())) * 0.04**3  # every particle's volume at rest
    assert rep["eroded_to_water_volume"] == pytest.approx(rep["eroded_volume_m3"] / water_m3, rel=1e-12)
    # this test's τ_c = 0.5, K_ε = 2 erode fast on purpose (1.6 times the water's volume in 0.3 s): warned
    assert rep["eroded_to_water_volume"] > 0.2
    assert [w for w in rep["warnings"] if w.startswith("The ground removed")]
    # profiles.csv: t,x,z along the centre line, x from the upstream toe; the first is the embankment's crest
    rows = np.loadtxt(out / "profiles.csv", delimiter=",", skiprows=1)
    assert (out / "profiles.csv").read_text().startswith("t,x,z\n")
    t0 = rows[rows[:, 0] == 0.0]
    # full preset: a 0.2 m embankment on a 2 cm plinth; the profile's peak is the crest at 0.22 m within a
    # voxel's interpolation error of the ramp (exact on planes; the crest's corners are rounded by < Δ)
    assert t0[:, 2].max() == pytest.approx(0.22, abs=0.04)
    crest = t0[t0[:, 2] > 0.2, 1]
    assert crest.min() >= 0.4 - 0.04 and crest.max() <= 0.5 + 0.04  # crest from 0.4 to 0.5 m past the toe
    assert len(np.unique(rows[:, 0])) >= 5
    # outputs per output time (0, 0.15, 0.3): every mesh format loads back, the fields too
    for k in range(3):
        for kind in ("obj", "ply", "glb"):
            m = trimesh.load(out / "meshes" / f"surface_{k:04d}.{kind}", force="mesh")
            assert len(m.faces) > 100
        VoxelTerrain.load(out / "fields" / f"density_{k:04d}.npz")
    assert (out / "figures" / "profiles.png").stat().st_size > 0
    # the frames carry each particle's label (`id`): unique and ascending, new ones for the inflow's
    # particles, and a particle keeps its own: between two frames 0.15 s apart it moved no further than
    # the larger of its two speeds carries it in that time, with a spacing for the change of speed; where this
    # test's fast erosion (τ_c = 0.5) opens the body, water rushes through faster between two frames than at
    # either, at most at the speed of a fall from the reservoir's level to the floor, sqrt(2 g 0.22 m)
    frames = read_pvd(out / "particles" / "particles.pvd")
    a, b = (read_vtp(out / "particles" / name) for _, name in frames[-2:])
    ia, ib = a["fields"]["id"], b["fields"]["id"]
    assert np.all(np.diff(ia) > 0) and np.all(np.diff(ib) > 0) and ib.max() > ia.max()
    both, ka, kb = np.intersect1d(ia, ib, return_indices=True)
    assert len(both) > 0.5 * len(ia)
    moved = np.linalg.norm(b["points"][kb] - a["points"][ka], axis=1)
    speed = np.maximum(np.linalg.norm(a["fields"]["velocity"][ka], axis=1),
                       np.linalg.norm(b["fields"]["velocity"][kb], axis=1))  # fmt: skip
    speed = np.maximum(speed, np.sqrt(2 * 9.81 * 0.22))
    assert np.all(moved <= speed * (frames[-1][0] - frames[-2][0]) + 0.04)
    # the non-erodible base (nodes below 0.03 m) kept every value it had
    start = VoxelTerrain.load(out / "fields" / "density_0000.npz")
    end = VoxelTerrain.load(out / "fields" / "density_0002.npz")
    z = start.axes()[2]
    low = z < 0.03
    assert np.array_equal(start.density[low], end.density[low])
    assert not np.array_equal(start.density[~low], end.density[~low])
    # and the surface never sank below the plinth's top (erosion.non_erodible_below = 0.02 m; 1e-6 m: float32)
    assert rows[:, 2].min() >= 0.02 - 1e-6


def test_eroding_more_than_a_fifth_of_the_waters_volume_is_warned():
    """Clear water carries up to about 20 % sediment by volume (Costa 1988); the fluid carries none, so a
    run that removes more is told so, with the setting to change."""
    from erosim.scenarios.voxel.outputs import sediment_warning

    assert sediment_warning(0.19, 1.0) is None and sediment_warning(1.0, 0.0) is None
    note = sediment_warning(0.32, 1.0)
    assert "0.32 of the water's volume" in note and "erosion.k_eps" in note
    assert "lower erosion.erodibility" in sediment_warning(0.32, 1.0, "erosion.erodibility")
    # at erosion.morfac = f the bed moves f times what the water eroded in its own time, which is what it carries
    assert sediment_warning(3.0, 1.0, morfac=20.0) is None
    note = sediment_warning(6.4, 1.0, morfac=20.0)
    assert "0.32 of the water's volume" in note and "0.32 m³ in flow time at erosion.morfac = 20" in note


def test_a_run_that_moved_no_ground_says_why():
    """Nothing transferred: erosion pending below a quantum names k_eps; none at all names the least speed
    along the surface that reaches τ_c, l_min (τ_c/K)^(1/n) (θ = v/l ≤ v/l_min): at h = 2 m (l_min =
    0.8 m), τ_c = 1.5, n = ½, that is 0.8 · 1.5² = 1.8 m/s."""
    from erosim.core.heightmap import Heightmap
    from erosim.erosion.shear_stress_kristof2009 import ShearStressErosion, ShearStressParams
    from erosim.scenarios.voxel.outputs import no_erosion_warning

    t = VoxelTerrain.from_heightmap(Heightmap(z=np.zeros((6, 6)), cell_size=1.0), cell_size=1.0)
    eroder = ShearStressErosion(t, ShearStressParams(tau_c=1.5, k_eps=1.0), support=2.0)
    note = no_erosion_warning(eroder)
    assert "faster than 1.8 m/s" in note and "erosion.tau_c" in note
    eroder.pending.flat[0] = 0.5 * eroder.params.quantum * (t.value_range[1] - t.value_range[0])
    note = no_erosion_warning(eroder)
    assert note.startswith("No ground was eroded yet") and "erosion.k_eps" in note
    eroder.removed_total = 1e-3
    assert no_erosion_warning(eroder) is None


def test_the_excess_shear_law_says_which_speed_it_needs():
    """Under the excess-shear law the least speed is the log law's at half a spacing up: √(τ_c/ρ) ln(30 z/k_s)/κ
    with z = 0.25 m (0.5 m particles), k_s = 0.05 m, τ_c = 4 Pa: 0.0632 · ln(150)/0.41 = 0.77 m/s; an
    erodibility of 0 asks for no erosion and is not warned."""
    from erosim.core.heightmap import Heightmap
    from erosim.erosion.excess_shear_partheniades1965 import ExcessShearErosion
    from erosim.scenarios.voxel.outputs import no_erosion_warning
    from erosim.scenarios.voxel.schema import VoxelErosion

    t = VoxelTerrain.from_heightmap(Heightmap(z=np.zeros((6, 6)), cell_size=1.0), cell_size=1.0)
    p = VoxelErosion(law="excess_shear", critical_stress=4.0, roughness=0.05)
    note = no_erosion_warning(ExcessShearErosion(t, p, support=1.0, spacing=0.5))
    assert "faster than 0.773 m/s" in note and "erosion.critical_stress = 4 Pa" in note
    off = VoxelErosion(law="excess_shear", erodibility=0.0)
    assert no_erosion_warning(ExcessShearErosion(t, off, support=1.0, spacing=0.5)) is None


# the excess-shear law at a bed shear stress the settling water, a few cm/s, passes within 0.3 s (1 mPa:
# u* = 1 mm/s), on a ground that retreats by 1 m/s per Pa of excess
EXCESS = ["erosion.law=excess_shear", "erosion.critical_stress=0.001", "erosion.erodibility=1.0"]


@pytest.mark.parametrize(("sediment", "law"), [("carried_off", []), ("suspended", []), ("carried_off", EXCESS)],
                         ids=["carried_off", "suspended", "excess_shear"])  # fmt: skip
def test_resume_after_ctrl_c_is_bit_identical(tmp_path, monkeypatch, sediment, law):
    """Also with the eroded ground carried by the particles and settling (their loads, the nodes' bound
    sediment and the budget's totals are in the checkpoint), and under the excess-shear law; the budget
    closes either way."""
    from erosim.sph.solver import SPHSolver

    sets = COARSE + ["run.output_interval=0", "run.particle_frames=false", f"erosion.sediment={sediment}", *law]
    whole = RunFolder(tmp_path / "whole")
    runner.run(loader.load("overtopping", sets, preset="full"), whole, progress=False)
    real, calls = SPHSolver.step, {"n": 0}

    def interrupt(self):
        calls["n"] += 1
        if calls["n"] == 500:
            raise KeyboardInterrupt
        return real(self)

    monkeypatch.setattr(SPHSolver, "step", interrupt)
    cut = RunFolder(tmp_path / "cut")
    with pytest.raises(Interrupted):
        runner.run(loader.load("overtopping", sets, preset="full"), cut, progress=False)
    monkeypatch.setattr(SPHSolver, "step", real)
    runner.run(loader.load(cut.path / "scenario.toml"), RunFolder(cut.path, resume=True), resume=True,
               progress=False)  # fmt: skip
    a = VoxelTerrain.load(whole.path / "fields" / "density_0001.npz").density
    b = VoxelTerrain.load(cut.path / "fields" / "density_0001.npz").density
    assert np.array_equal(a, b)
    assert (whole.path / "profiles.csv").read_text() == (cut.path / "profiles.csv").read_text()
    ra, rb = (json.loads((p / "report.json").read_text()) for p in (whole.path, cut.path))
    assert ra["eroded_volume_m3"] > 0
    assert ra["eroded_volume_m3"] == rb["eroded_volume_m3"] and ra["first_erosion"] == rb["first_erosion"]
    assert ra["steps"] == rb["steps"] and ra["fluid_particles"] == rb["fluid_particles"]
    assert ra["budget"] == rb["budget"] and ra["budget"]["closure_rel"] < 1e-9
    if sediment == "suspended":
        assert ra["sediment"] == rb["sediment"]
        assert ra["sediment"]["picked_up_m3"] > 0 and ra["budget"]["deposited"] > 0


@pytest.mark.parametrize(
    "sets, words",
    [
        (["voxels.iso=1.5"], "iso level 1.5 lies outside"),
        (["voxels.cell_size=0.1"], "too coarse for the particle spacing"),
        (["voxels.max_bytes=1000"], "use voxels of at least"),
        (["embankment.x_toe=1.0"], "beyond the flume's end"),
        (["inflows.j.position=[0.1, 0.05]", "inflows.j.discharge=0.001"], "jets stand on a heightmap"),
        (["voxels.scale=dem"], "a flume has none"),
    ],
)
def test_bad_input_is_one_sentence_and_leaves_no_run_folder(tmp_path, sets, words):
    out = tmp_path / "bad"
    code, text = _cli("run", "overtopping", "--out", str(out), *_sets(COARSE + sets))
    assert code != 0
    assert words in " ".join(text.split()), text
    assert not out.exists()


@pytest.mark.slow
def test_validate_overtopping_default_resolution(tmp_path):
    """The seed's observations at the library's resolution (both presets, 60 s each): see
    erosim.validation.overtopping for the criteria."""
    from erosim.validation.overtopping import run as validate

    res = validate("default", tmp_path / "v", progress=False)
    assert res["runs"]["partial"]["particles_inside_solid"] == 0
    assert res["runs"]["full"]["particles_inside_solid"] == 0
    assert res["passed"], res


def test_canyon_caves_second_run_starts_from_the_first_runs_field(tmp_path):
    sets = ["terrain.size=12", "run.t_end=0.6", "run.output_interval=0.3", "erosion.start=0.05",
            "run.particle_frames=false", "rain.height=0.5", "inflows.river.position=[5.5, 1.5]"]  # fmt: skip
    first, second = tmp_path / "first", tmp_path / "second"
    code, text = _cli("run", "canyon-caves", "--out", str(first), *_sets(sets))
    assert code == 0, text
    end = first / "fields" / "density_0002.npz"
    code, text = _cli("run", "canyon-caves", "--out", str(second), *_sets(sets + [f"terrain.voxels_file={end}"]))
    assert code == 0, text
    a = VoxelTerrain.load(end)
    b = VoxelTerrain.load(second / "fields" / "density_0000.npz")
    assert np.array_equal(a.density, b.density) and a.cell_size == b.cell_size and a.origin == b.origin
    for run in (first, second):
        assert all((run / "figures" / f"section_{k:04d}.png").stat().st_size > 0 for k in range(3))
        with Image.open(run / "figures" / "surface.png") as im:  # run.surface_figure: 11 × 4.6 in at 110 dpi
            assert im.size == (1210, 506)
        rep = json.loads((run / "report.json").read_text())
        assert rep["particles_inside_solid"] == 0
        assert rep["water"]["added"].get("rain", 0) > 0  # drops of 5 particles
        assert rep["water"]["added"]["rain"] % 5 == 0
        assert rep["water"]["added"]["inflow:river"] > 0  # the stream falling in from the west plateau


def test_a_jet_on_a_heightmap_feeds_the_valley_floor(tmp_path):
    """[inflows.NAME] on a voxel heightmap: a layer of the jet's disc every Δx/speed seconds, its mouth
    ``height`` above the top surface at ``position``; a position off the map is one sentence."""
    from erosim.scenarios.voxel.build import build_solver, build_terrain, jets
    from erosim.scenarios.voxel.outputs import top_surface

    sets = ["terrain.size=12", "run.t_end=1.0", "run.output_interval=1.0", "erosion.enabled=false",
            "run.particle_frames=false", "rain.rate=0", "inflows.river.position=[5.5, 2.0]",
            "inflows.river.discharge=2.0", "inflows.river.radius=0.5", "inflows.river.height=1.0"]  # fmt: skip
    cfg = loader.load("canyon-caves", sets).config
    t = build_terrain(cfg)
    (jet,) = jets(cfg, t, build_solver(cfg, t)[0])
    # the disc of radius 0.5 m on the 0.5 m lattice: the centre and its four neighbours (1.25 m²), so the
    # water leaves at Q/A = 1.6 m/s, a layer every Δx/1.6 = 0.3125 s: three layers in 1 s
    assert len(jet.layer) == 5 and jet.speed == pytest.approx(1.6) and jet.period == pytest.approx(0.3125)
    c = t.cell_size
    ground = top_surface(t)[int(round((2.0 - t.lo[1]) / c)), int(round((5.5 - t.lo[0]) / c))]
    assert np.allclose(jet.layer[:, 2], jet.layer[0, 2]) and jet.layer[0, 2] >= ground + 1.0
    assert jet.layer[0, 2] < ground + 1.0 + 0.5  # the highest ground under the disc, within a cell's slope
    out = tmp_path / "jet"
    code, text = _cli("run", "canyon-caves", "--out", str(out), *_sets(sets))
    assert code == 0, text
    rep = json.loads((out / "report.json").read_text())
    assert rep["water"]["added"] == {"inflow:river": 15}
    code, text = _cli("run", "canyon-caves", "--out", str(tmp_path / "off"),
                      *_sets(sets + ["inflows.river.position=[30, 2]"]))  # fmt: skip
    assert code != 0 and "lies outside the terrain" in " ".join(text.split()), text
    assert not (tmp_path / "off").exists()


@pytest.mark.slow
@pytest.mark.parametrize("spacing", [0.02, 0.015])
def test_excess_shear_erodes_a_resistant_embankment_low_at_either_spacing(tmp_path, spacing):
    """Under the excess-shear law the same soil (τ_c = 5 Pa, between the overflow's 2–4 Pa at mid-slope and its
    5–8 Pa on the lower slope at both spacings, docs/voxel.md) first loses ground in the lower half of the
    downstream slope (0.70–0.90 m from the toe, one voxel's tolerance) at 2 and at 1.5 cm, where the seed's
    law moves from 0.72 to 0.59 m; the crest stands (4 s: 80 s and 230 s on one thread)."""
    sets = ["erosion.law=excess_shear", "erosion.critical_stress=5.0", "erosion.erodibility=0.02",
            f"sph.spacing={spacing}", f"voxels.cell_size={spacing}", "run.t_end=4.0", "run.output_interval=0",
            "run.particle_frames=false"]  # fmt: skip
    folder = RunFolder(tmp_path / "run")
    runner.run(loader.load("overtopping", sets, preset="partial"), folder, progress=False)
    rep = json.loads((folder.path / "report.json").read_text())
    fe = rep["first_erosion"]
    assert fe is not None and 0.70 - spacing <= fe["x"] <= 0.90 + spacing, fe
    prof = np.loadtxt(folder.path / "profiles.csv", delimiter=",", skiprows=1)
    assert prof[prof[:, 0] == prof[-1, 0], 2].max() == pytest.approx(0.2, abs=spacing / 2)


def test_wall_attraction_is_a_setting_that_reaches_the_wall():
    """voxels.attraction (SPEC VX-5): 'none' leaves the wall repulsive only (ρ₁ = 0), 'seed' gives the seed's
    ρ₁ = ρ₀ + m W(0) (above ρ₀ by one particle's own share), a number is ρ₁ itself; anything else is refused in one
    sentence when the scenario is loaded."""
    from erosim.core.errors import ConfigError
    from erosim.scenarios.voxel.build import build_solver, build_terrain
    from erosim.sph.boundaries.voxel_wall import VoxelWall

    rho1 = {}
    for value in ("none", "seed", 1010.0):
        cfg = loader.load("overtopping", [*COARSE, f"voxels.attraction={value!r}" if isinstance(value, str)
                                          else f"voxels.attraction={value}"]).config  # fmt: skip
        solver, wall, _ = build_solver(cfg, build_terrain(cfg))
        assert isinstance(wall, VoxelWall)
        rho1[value] = wall.rho1
    rho0 = cfg.sph.rho0
    assert rho1["none"] == 0.0 and rho1[1010.0] == 1010.0
    assert rho0 < rho1["seed"] < 1.5 * rho0  # ρ₀ plus one particle's W(0) share of the lattice's density
    for bad in ("-5.0", "'bogus'"):
        with pytest.raises(ConfigError, match="give ρ₁ as a positive density in kg/m³, or 'seed' or 'none'"):
            loader.load("overtopping", [*COARSE, f"voxels.attraction={bad}"])
