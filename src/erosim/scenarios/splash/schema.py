"""Schema of ``kind = "splash"`` scenarios: water on porous ground that it wets, weakens and splashes
(seed 003; SPEC SP-1…SP-6).

::

    seed = 1
    [terrain]          the heightmap (erosim.scenarios.schema_common.TerrainSection); ignored with [drop]
    [sph]              solver parameters (erosim.sph.params.SPHParams); spacing = the fluid particles' size
    [scale]            spacing_cells: the fluid spacing in terrain cells (a DEM's own scale), instead of sph.spacing
    [ground]           porous ground particles: spacing, layers, porosity, saturation, grain density,
                       strengths σ₀ (dry) and σ₁ (wet), permeability, moisture diffusivity, evaporation
    [drop]             one drop, or a column of drops, of radius R at speed V on a flat patch (splash-drop)
    [rain]             rain on the terrain (as sph-terrain's [rain]); [inflows.NAME] vertical jets
    [edges]            outflow = ["east", ...]: open edges (water and mud leaving are counted)
    [splash]           crater law settings (contact distance, smallest speed, most mud a particle takes up)
    [scour]            shear-stress scour of the ground by moving water (Krištof et al. 2009)
    [mud]              grain density and viscosity in the mixture, concentration diffusivity
    [run]              t_end, coupling interval, particle frames, wetness frames, checkpoints
"""

from __future__ import annotations

from pydantic import Field, model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError
from erosim.coupling.splash_coupler import ScourParams
from erosim.erosion.splash import SplashParams
from erosim.erosion.wet_strength import WetStrengthParams
from erosim.scenarios.schema_common import TerrainSection, with_sph_defaults
from erosim.scenarios.sph_terrain.schema import EdgesSection, InflowSection, RainSection
from erosim.sph.mud import MudParams
from erosim.sph.params import SPHParams

#: the ground spacing may be the fluid's divided by a whole number up to this
MAX_GROUND_REFINEMENT = 8


class PorousGroundSection(WetStrengthParams):
    """The porous ground particles under the terrain surface (sigma_dry, sigma_wet from WetStrengthParams)."""

    spacing: float = param(0.0, ge=0, unit="m", doc="ground particle spacing: 0 = the fluid's; otherwise the fluid's "
                           f"divided by a whole number 1…{MAX_GROUND_REFINEMENT}")  # fmt: skip
    layers: int = param(4, ge=1, le=64, unit="1", doc="layers of ground particles under the surface")
    porosity: float = param(0.4, gt=0, lt=1, unit="1", doc="porosity φ: pore volume per particle volume (< 1)")
    saturation: float = param(0.0, ge=0, le=1, unit="1", doc="initial saturation θ of every ground particle, 0…1")
    density: float = param(2650.0, gt=0, unit="kg/m3", doc="density of the ground's grains")
    permeability: float = param(1.0e-9, ge=0, unit="m2", doc="intrinsic permeability k_p (K = k_p ρ g/μ); of "
                                "the top soil where topsoil_layers > 0")  # fmt: skip
    topsoil_layers: int = param(0, ge=0, le=63, unit="1", doc="layers of top soil of ground.permeability over a "
                                "subsoil of ground.subsoil_permeability (0: one uniform ground)")  # fmt: skip
    subsoil_permeability: float = param(0.0, ge=0, unit="m2", doc="permeability of the layers under the top soil "
                                        "(with topsoil_layers > 0)")  # fmt: skip
    diffusivity: float = param(1.0e-4, ge=0, unit="m2/s", doc="moisture diffusivity D_θ between ground particles")
    evaporation: float = param(0.0, ge=0, unit="mm/h", doc="evaporation from the surface particles")


class DropSection(Section):
    """Drops on a flat patch: each drop is one fluid particle of the drop's volume (the crater law's R)."""

    radius: float = param(2.0e-3, gt=0, unit="m", doc="drop radius R (sets the fluid spacing: the drop's volume)")
    speed: float = param(4.0, ge=0, unit="m/s", doc="speed V of the drops towards the ground at the start")
    count: int = param(1, ge=1, le=1000, unit="1", doc="drops in a vertical column (one after the other)")
    gap: float = param(3.0, ge=1, unit="diameters", doc="distance between successive drops of the column")
    cells_per_radius: float = param(4.0, ge=1, le=40, unit="1", doc="heightmap cells per drop radius")
    patch: float = param(12.0, ge=4, le=400, unit="radii", doc="width of the flat patch")


class ScaleSection(Section):
    spacing_cells: float | None = param(None, gt=0, le=2, unit="cells", doc="fluid spacing in terrain cells "
                                        "(follows a DEM's own cell size); none: sph.spacing")  # fmt: skip
    reference_cell: float | None = param(None, gt=0, unit="m", doc="the cell size the scenario's values are for: "
                                         "on a terrain of another cell size every dimensional value is scaled by "
                                         "Froude similarity (lengths ∝ λ, times and speeds ∝ √λ); none: no "
                                         "scaling")  # fmt: skip
    sound_factor: float = param(10.0, ge=3, le=40, unit="1", doc="sound speed as a multiple of the fastest water "
                                "expected (drops, jets, the highest fall), unless sph.sound_speed is set")  # fmt: skip
    max_ground: int = param(200_000, ge=0, le=2_000_000, unit="particles", doc="on a terrain whose porous ground "
                            "would need more particles than this, the fluid and ground particles are coarsened "
                            "together (their ratio kept) until it fits, and the console says so; 0: never coarsen "
                            "(refuse beyond 2 million instead)")  # fmt: skip


class SplashRun(Section):
    t_end: float = param(0.02, gt=0, unit="s", doc="simulated time to reach")
    every: int = param(1, ge=1, unit="steps", doc="SPH steps between two couplings of water and ground")
    rain_until: float | None = param(None, gt=0, unit="s", doc="the rain stops at this time (none: it rains "
                                     "throughout); the ground then drains and dries")  # fmt: skip
    output_interval: float = param(0.0, ge=0, unit="s", doc="particle frames (.vtp, with water share and mud) every "
                                   "this long; 0: none")  # fmt: skip
    wetness_frames: int = param(0, ge=0, le=400, unit="1", doc="wetness and height map frames over the run")
    checkpoint_wall_s: float = param(300.0, gt=0, unit="s", doc="wall-clock time between checkpoints")


class SplashScenario(Section):
    seed: int = param(1, ge=0, doc="random seed (terrain, rain)")
    terrain: TerrainSection = Field(default_factory=lambda: TerrainSection(preset="flat", size=64, cell_size=0.01))
    sph: SPHParams = Field(default_factory=lambda: SPHParams(dim=3, walls="reflect", spacing=0.005))
    scale: ScaleSection = Field(default_factory=ScaleSection)
    ground: PorousGroundSection = Field(default_factory=PorousGroundSection)
    drop: DropSection | None = None
    rain: RainSection = Field(default_factory=RainSection)
    inflows: dict[str, InflowSection] = {}
    edges: EdgesSection = Field(default_factory=EdgesSection)
    splash: SplashParams = Field(default_factory=SplashParams)
    scour: ScourParams = Field(default_factory=ScourParams)
    mud: MudParams = Field(default_factory=MudParams)
    run: SplashRun = Field(default_factory=SplashRun)

    @property
    def profile(self):
        """Splash runs are 3-D (no [profile]); sph-terrain's geometry reads this."""
        return None

    @model_validator(mode="before")
    @classmethod
    def _derive(cls, data):
        return with_sph_defaults(data, dim=3, walls="reflect")

    @model_validator(mode="after")
    def _check(self) -> SplashScenario:
        if self.sph.dim != 3:
            raise ConfigError(f"sph.dim = {self.sph.dim} but splash runs are 3-D; leave sph.dim out.")
        if self.sph.walls != "reflect":
            raise ConfigError("In splash scenarios the ground and the map edges are the walls; leave sph.walls out.")
        if self.drop is None and self.rain.rate <= 0 and not self.inflows:
            raise ConfigError("The scenario has no water: give a [drop], rain.rate > 0 or an [inflows.NAME] jet.")
        g = self.ground
        if g.topsoil_layers >= g.layers:
            raise ConfigError(f"ground.topsoil_layers = {g.topsoil_layers} leaves no subsoil in {g.layers} layers; "
                              "give fewer top soil layers than ground.layers, or 0 for a uniform ground.")  # fmt: skip
        if g.topsoil_layers > 0 and g.subsoil_permeability <= 0:
            raise ConfigError("ground.topsoil_layers > 0 needs ground.subsoil_permeability > 0 (m²) for the layers "
                              "under the top soil.")  # fmt: skip
        if g.topsoil_layers == 0 and g.subsoil_permeability > 0:
            raise ConfigError("ground.subsoil_permeability is set but ground.topsoil_layers is 0; give the number of "
                              "top soil layers, or leave subsoil_permeability out.")  # fmt: skip
        for name, inf in self.inflows.items():
            if len(inf.position) != 2:
                raise ConfigError(f"inflows.{name}.position has {len(inf.position)} coordinates; give [x, y].")
        return self


def ground_spacing(fluid_spacing: float, ground: PorousGroundSection) -> float:
    """The ground particles' spacing: the fluid's, or the fluid's over a whole number (else one sentence)."""
    if ground.spacing == 0:
        return fluid_spacing
    ratio = fluid_spacing / ground.spacing
    k = round(ratio)
    if k < 1 or k > MAX_GROUND_REFINEMENT or abs(ratio - k) > 1e-6 * ratio:
        raise ConfigError(
            f"ground.spacing = {ground.spacing:g} m does not fit the fluid spacing {fluid_spacing:g} m (ratio "
            f"{ratio:.4g}); give the fluid's spacing divided by a whole number 1…{MAX_GROUND_REFINEMENT}, or 0 for the "
            "fluid's own."
        )
    return fluid_spacing / k
