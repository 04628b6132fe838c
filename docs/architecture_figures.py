"""The two pictures of docs/architecture.md, drawn from the code: the layers with the import edges between
packages (read from the sources' imports, lazy ones too, as tests/unit/package/test_layering.py reads them), and
one coupled step. Also prints the package graph's size (modules, packages, edges).

    .venv/bin/python docs/architecture_figures.py [--src src] [--out docs/images]
"""

from __future__ import annotations

import argparse
import ast
from collections import Counter
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

# the layers, lowest first (tests/unit/package/test_layering.py's ranks, grouped as docs/architecture.md draws them)
LAYERS = [
    ("foundation", ["core"]),
    ("files, pictures, measurements, data, Numba kernels", ["io", "viz", "analysis", "data", "kernels"]),
    ("physics, one method per module", ["sph", "terrain", "erosion", "hydrology"]),
    ("fluid ↔ terrain", ["coupling"]),
    ("the run", ["simulation"]),
    ("kinds: schema, build, outputs", ["scenarios"]),
    ("uses of a run", ["validation", "api", "view"]),
    ("many runs", ["sweep"]),
    ("large DEMs, throughput", ["tiles", "bench"]),
    ("command line", ["cli"]),
]


def package_edges(src: Path) -> tuple[int, Counter]:
    """(number of modules, Counter of (importing package, imported package) → module-level edges)."""
    pkg = src / "erosim"
    edges: Counter = Counter()
    modules = 0
    for path in sorted(pkg.rglob("*.py")):
        modules += 1
        here = path.relative_to(pkg).parts
        p = here[0].removesuffix(".py") if len(here) > 1 or here[0] != "__init__.py" else "erosim"
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            for n in names:
                parts = n.split(".")
                if parts[0] == "erosim" and len(parts) > 1:
                    targets.add(parts[1])
        for q in targets:
            if q != p:
                edges[(p, q)] += 1
    return modules, edges


def draw_layers(edges: Counter, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(11, 8.5))
    pos = {}
    for row, (label, pkgs) in enumerate(LAYERS):
        y = row * 1.0
        for k, name in enumerate(pkgs):
            x = 1.6 + k * 1.7
            pos[name] = (x, y)
            ax.add_patch(FancyBboxPatch((x - 0.65, y - 0.22), 1.3, 0.44, boxstyle="round,pad=0.02",
                                        fc="#dde8f3", ec="#34587a"))  # fmt: skip
            ax.text(x, y, name, ha="center", va="center", fontsize=10)
        ax.text(9.3, y, label, ha="left", va="center", fontsize=8.5, color="#555555")
    for (p, q), n in edges.items():
        if p not in pos or q not in pos:
            continue
        (x0, y0), (x1, y1) = pos[p], pos[q]
        ax.add_patch(FancyArrowPatch((x0, y0 - 0.22), (x1, y1 + 0.22), arrowstyle="-|>", mutation_scale=7,
                                     lw=0.4 + 0.25 * min(n, 12), color="#7a7a7a", alpha=0.45,
                                     connectionstyle="arc3,rad=0.08"))  # fmt: skip
    ax.set_xlim(0.7, 12.6)
    ax.set_ylim(-0.6, len(LAYERS) - 0.4)
    ax.axis("off")
    total = sum(edges.values())
    ax.set_title(f"erosim's layers: imports go downward only ({len(edges)} package pairs, {total} module imports "
                 "across packages; line width ∝ their number)", fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


STEP = [
    ("SPHSolver.advance() × N", "the fluid steps; the coupler's schedule fires every erosion.every steps"),
    ("fluid = terrain.fluid(solver)", "heightfield: particles binned on the raster;\nvoxel field: the particles"),
    ("eroder.increments(terrain, fluid, Δt)", "reads only → Increment(Δ per node, ΔS, C, particles' new loads)"),
    ("check_budget · terrain.refuse", "Σ Δ·A + ΔS + C = 0 to 1e-9; never below the bedrock"),
    ("particle fields written", "the sediment each particle carries"),
    ("with solver.ground_moving(values, Δ≠0):\n    terrain.apply(Δ, t)", "walls' share kept; every boundary refreshed"),
    ("budget += terms", "report: sediment_budget (heightfield) or the voxel kind's erosion.budget"),
]  # fmt: skip


def draw_step(path: Path) -> None:
    fig, ax = plt.subplots(figsize=(10, 6))
    n = len(STEP)
    for k, (what, why) in enumerate(STEP):
        y = n - 1 - k
        ax.add_patch(FancyBboxPatch((0.2, y - 0.3), 4.6, 0.6, boxstyle="round,pad=0.02",
                                    fc="#fbe9d0" if k else "#dde8f3", ec="#8a5a20" if k else "#34587a"))  # fmt: skip
        ax.text(2.5, y, what, ha="center", va="center", fontsize=9.5, family="monospace")
        ax.text(5.0, y, why, ha="left", va="center", fontsize=9)
        if k:
            ax.add_patch(FancyArrowPatch((2.5, y + 0.7), (2.5, y + 0.3), arrowstyle="-|>", mutation_scale=10))
    ax.set_xlim(0, 11.5)
    ax.set_ylim(-0.6, n - 0.4)
    ax.axis("off")
    ax.set_title("One coupled step (coupling/coupler.py): the coupler is the only writer of the terrain", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, default=Path(__file__).resolve().parents[1] / "src")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "images")
    a = ap.parse_args()
    modules, edges = package_edges(a.src)
    packages = {p for p, _ in edges} | {q for _, q in edges}
    print(f"modules {modules}, packages {len(packages)}, package pairs {len(edges)}, "
          f"module imports across packages {sum(edges.values())}")  # fmt: skip
    draw_layers(edges, a.out / "architecture_layers.png")
    draw_step(a.out / "architecture_coupled_step.png")


if __name__ == "__main__":
    main()
