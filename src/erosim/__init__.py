"""erosim: particle-based terrain erosion and flood simulation."""

import hashlib
import os
import re
import sys
from pathlib import Path

# Numba's threading layer. Imported as a library, erosim asks for workqueue: it is fork-safe, so a program
# may run erosim and then fork worker processes (multiprocessing's default on Linux before Python 3.14),
# where GNU OpenMP stops a forked child at its first parallel loop. The `erosim` command starts its
# workers by spawning them and asks for OpenMP instead (:func:`command_threading_layer`).
_USER_LAYER = "NUMBA_THREADING_LAYER" in os.environ
os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")


def command_threading_layer() -> None:
    """The `erosim` command's threading layer, unless NUMBA_THREADING_LAYER was set: OpenMP where the system
    has it (libgomp; else workqueue), its threads sleeping between parallel loops (OMP_WAIT_POLICY=passive)
    rather than spinning, which on a machine shared with other work cost ~1 ms a loop. On the 2-core
    machine workqueue ran the SPH benchmark 5-45 % and the droplet batches at 1024² 25-35 % slower, idle or
    with one core taken by another job (docs/performance.md, "Threading layer"). Both layers split a prange
    loop into the same fixed chunks, so results do not depend on the layer. Set in the environment, the
    choice reaches the Dask workers the command spawns. Call before any parallel loop has run."""
    if _USER_LAYER:
        return
    os.environ["NUMBA_THREADING_LAYER"] = "default"
    os.environ.setdefault("NUMBA_THREADING_LAYER_PRIORITY", "omp workqueue tbb")
    os.environ.setdefault("OMP_WAIT_POLICY", "passive")
    if "numba" in sys.modules:  # imported already: its config has read the environment
        cfg = sys.modules["numba"].config
        cfg.THREADING_LAYER = "default"
        cfg.THREADING_LAYER_PRIORITY = os.environ["NUMBA_THREADING_LAYER_PRIORITY"].split()


__version__ = "0.1.0"

#: compiled-kernel caches kept side by side (older ones are removed)
_CACHES_KEPT = 4


def source_hash(pkg: Path) -> str:
    """16 hex digits of the SHA-256 of every ``.py`` file under ``pkg`` (names and contents)."""
    digest = hashlib.sha256()
    for path in sorted(pkg.rglob("*.py")):
        digest.update(path.relative_to(pkg).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _numba_cache_dir() -> None:
    """Put Numba's on-disk cache of compiled kernels in a folder named by a hash of this package's
    sources, ``<root>/<version>-<hash>``; the root is ``$NUMBA_CACHE_DIR`` when the user sets it,
    else ``~/.cache/erosim/numba`` (``$XDG_CACHE_HOME`` honoured).

    Numba keys a cached function by its own file only: a jitted caller that inlines a callee from
    another file (a kernel, a boundary pass) stays cached when only the callee's file changes, so a
    run after an edit could execute the old physics. A folder per source hash makes that impossible,
    wherever the cache lives; the newest few such folders are kept under the root.
    """
    name = f"{__version__}-{source_hash(Path(__file__).resolve().parent)}"
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        root = Path(user)
        if root.name == name:  # already resolved (a child process inherits the folder, not the root)
            root = root.parent
    else:
        root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "erosim" / "numba"
    folder = root / name
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)
        ours = re.compile(r"^.+-[0-9a-f]{16}$")  # only this package's folders are pruned, never others'
        old = sorted((p for p in root.iterdir() if p.is_dir() and p != folder and ours.match(p.name)),
                     key=lambda p: p.stat().st_mtime)  # fmt: skip
        for stale in old[: max(0, len(old) - (_CACHES_KEPT - 1))]:
            import shutil

            shutil.rmtree(stale, ignore_errors=True)
    except OSError:  # no writable cache root: Numba's default cache beside the sources
        if user:
            os.environ.pop("NUMBA_CACHE_DIR")
            if "numba" in sys.modules:
                sys.modules["numba"].config.CACHE_DIR = ""
        return
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:  # imported before erosim: its config has read the environment already
        sys.modules["numba"].config.CACHE_DIR = str(folder)


_numba_cache_dir()


# ------------------------------------------------------------------------------------ Python API
# Imported on first use (module __getattr__), so `import erosim` stays cheap; docs/api.md.
_LAZY = {
    "run": "erosim.api:run",
    "RunResult": "erosim.api:RunResult",
    "load_scenario": "erosim.api:load_scenario",
    "run_sweep": "erosim.sweep.runner:run_sweep",
    "Scenario": "erosim.scenarios.loader:Scenario",
    "ErosimError": "erosim.core.errors:ErosimError",
    "Heightmap": "erosim.core.heightmap:Heightmap",
    "generate_terrain": "erosim.terrain.generate:generate",
    "HydrologyModel": "erosim.hydrology.model:HydrologyModel",
    "HydrologyParams": "erosim.hydrology.params:HydrologyParams",
    "VegetationParams": "erosim.hydrology.params:VegetationParams",
    "SPHSolver": "erosim.sph.solver:SPHSolver",
    "SPHParams": "erosim.sph.params:SPHParams",
    "ParticleStream": "erosim.erosion.particle_stream_warszawski:ParticleStream",
    "Emitter": "erosim.erosion.particle_stream_warszawski:Emitter",
    "TransportCapacity": "erosim.erosion.transport_capacity_mei2007:TransportCapacity",
    "TransportCapacityParams": "erosim.erosion.transport_capacity_mei2007:TransportCapacityParams",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'erosim' has no attribute '{name}'")
    import importlib

    module, _, attr = _LAZY[name].partition(":")
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
