"""Validation: the same drop digs a shallow crater in dry ground, a deeper one in partly wet ground and
the deepest in saturated ground (seed 003 fig. 7; SPEC SP-1, SP-2, SP-6).

Three ``splash-drop`` runs at equal impact (drop radius R, speed V) on ground of saturation 0, 0.5 and
1. Each crater is measured on the heightmap and compared with the law d_p = R·v·√(2ρ_f/(9σ_s(θ))) at
the measured impact speed. Passed when the depths are ordered dry < partly wet < saturated, each
measured depth is the law's to 1e-6 (the drop strikes a node of the heightmap, where the imprint's
depth is exactly d_p; the difference is rounding) and both budgets close to 1e-9. Writes
``figures/craters.png`` (the three sections side by side) and ``validation.json``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from erosim.core import atomic
from erosim.core.errors import ConfigError
from erosim.io.runfolder import RunFolder, default_out

SATURATIONS = (0.0, 0.5, 1.0)
LABELS = ("dry (θ = 0)", "partly wet (θ = 0.5)", "saturated (θ = 1)")
RESOLUTIONS = {"coarse": 3.0, "default": 4.0, "fine": 8.0}  # heightmap cells per drop radius


def run(resolution: str = "default", out: Path | None = None, progress: bool = True, speed: float = 4.0,
        radius: float = 0.002) -> dict:  # fmt: skip
    """The three runs, the comparison and the figure."""
    import json

    from erosim.io import heightmaps as hio
    from erosim.scenarios import loader, runner
    from erosim.viz.splash import craters_side_by_side

    if resolution not in RESOLUTIONS:
        raise ConfigError(f"Unknown resolution '{resolution}'; use one of: {', '.join(RESOLUTIONS)}.")
    folder = RunFolder(out if out is not None else default_out(f"validate-splash-wetness-{resolution}"))
    rows, sections = [], []
    for theta, label in zip(SATURATIONS, LABELS, strict=True):
        sub = folder.path / f"saturation_{theta:g}"
        sets = [f"ground.saturation={theta!r}", f"drop.speed={speed!r}", f"drop.radius={radius!r}",
                f"drop.cells_per_radius={RESOLUTIONS[resolution]!r}"]  # fmt: skip
        runner.run(loader.load("splash-drop", sets), RunFolder(sub, overwrite=True), progress=progress)
        rep = json.loads((sub / "report.json").read_text(encoding="utf-8"))
        law = rep["crater_law"]
        rows.append({
            "saturation": theta,
            "sigma_pa": law["sigma_pa"],
            "impact_speed_m_s": law["impact_speed_m_s"],
            "crater_depth_m": rep["crater_depth_m"],
            "law_depth_m": law["depth_m"],
            "crater_width_m": rep["crater_width_m"],
            "law_width_m": law["width_m"],
            "water_closure_rel": rep["water_budget"]["closure_rel"],
            "solid_closure_rel": rep["solid_budget"]["closure_rel"],
        })  # fmt: skip
        z = hio.read(sub / "maps" / "height.tif").z
        z0 = hio.read(sub / "maps" / "height_initial.tif").z
        j, i = np.unravel_index(int(np.argmax(z0 - z)), z.shape)
        cell = rep["terrain"]["cell_size_m"]
        x = (np.arange(z.shape[1]) - i) * cell * 1e3
        keep = np.abs(x) <= 3 * radius * 1e3
        sections.append((f"{label}\nd = {rep['crater_depth_m'] * 1e3:.2f} mm", x[keep], z[j][keep] * 1e3))
    path = folder.figures / "craters.png"
    craters_side_by_side(path, sections, f"One drop, R = {radius * 1e3:g} mm at {speed:g} m/s, on ground of three "
                         "saturations")  # fmt: skip
    depths = [r["crater_depth_m"] for r in rows]
    ordered = depths[0] < depths[1] < depths[2]
    worst = max(abs(r["crater_depth_m"] - r["law_depth_m"]) / r["law_depth_m"] for r in rows)
    closes = all(r["water_closure_rel"] < 1e-9 and r["solid_closure_rel"] < 1e-9 for r in rows)
    result = {
        "case": "splash-wetness",
        "metric": "largest relative difference of a measured crater depth from the law d_p = R v √(2ρ/(9σ(θ)))",
        "value": worst,
        "threshold": 1e-6,
        "passed": bool(ordered and worst < 1e-6 and closes),
        "ordered_dry_partly_saturated": bool(ordered),
        "depth_ratio_saturated_to_dry": depths[2] / depths[0],
        "expected_ratio": math.sqrt(rows[0]["sigma_pa"] / rows[2]["sigma_pa"])
        * rows[2]["impact_speed_m_s"]
        / rows[0]["impact_speed_m_s"],
        "runs": rows,
        "out": str(folder.path),
        "resolution": resolution,
        "figure": str(path.relative_to(folder.path)),
    }
    atomic.write_json(folder.path / "validation.json", result)
    return result
