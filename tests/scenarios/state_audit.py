"""What a checkpoint forgets: a run stopped after N iterations against a fresh build restored from its checkpoint.

:func:`audit` builds a scenario's run, advances it N iterations exactly as ``Simulation.run`` does
(callbacks fired after every step), writes its checkpoint, builds the run a second time into the same
folder and restores it, then walks both object graphs (the models and the callbacks, attribute by
attribute, into arrays, lists, dicts and the objects they hold) and returns the paths where they
differ. Every path is a piece of state the next steps may read that the checkpoint did not carry,
unless it is a cache the next step rebuilds before reading (those are named in ``IGNORED``, with the sessions' clocks).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from types import BuiltinFunctionType, FunctionType, MethodType, ModuleType

import numpy as np

# what may differ (path pattern → why): the sessions' clocks, and caches the next step writes in full
# before it reads them
IGNORED: dict[str, str] = {
    "*.wall": "wall time spent (this session)",
    "*.wall[*": "wall time spent (this session)",
    "*.cpu[*": "CPU time spent (this session)",
    "*._end": "the clock reading at the end of the last pass (this session)",
    "*.clock.end": "the splash passes' clock reading at the end of the last coupling (this session)",
    "*.schedule._banked": "a wall-time schedule's running time (sessions differ)",
    "*.schedule._since": "a wall-time schedule's clock reading (this session)",
    "model[*]._a2": "the SPH step's per-chunk maxima of |a|², written before they are read",
    "model[*]._v2": "the SPH step's per-chunk maxima of |u|², written before they are read",
    "model[*]._disp2": "per-chunk displacements since the last list rebuild, written before they are read",
    "model[*]._krate": "per-particle diffusion rates, written by the force pass before their maximum is taken",
    "model[*]._cstart": "slot offsets of a neighbour-list build, written at the build",
    "model[*]._count_f": "slot sizes of a list build (a too small one only makes the build count again)",
    "model[*]._count_b": "slot sizes of a list build (a too small one only makes the build count again)",
    "model[*]._tcount": "scratch of the boundary lists' transposition",
    "model[*]._tmp": "scratch of a neighbour-list build",
    "model[*]._grid.*": "the hash grid of the last list build, rebuilt from the positions at the next one",
    "model[*]._shifting._buf[*": "the shifting pass's scratch, written in full before it is read",
    "model[*].state._store[*": "spare rows of the particle stores; the active rows are compared as the views",
    "model[*].state.capacity": "the particle stores' size (spare rows included)",
    "model[*].state.fluid_capacity": "the particle stores' fluid rows (spare rows included)",
    "model[hydrology].stack": "the lake heaps' scratch stack",
    "model[hydrology].walk": "the lake heaps' scratch walk",
    # the parallel batches' results and logs are set at each batch's start or written before they are read,
    # and a cycle (the unit a checkpoint falls between) ends its batches; the per-thread overlay (index 4)
    # returns to zero after each droplet and is compared
    "model[hydrology]._work[0]": "a batch's droplet results, set when the batch starts",
    "model[hydrology]._work[1]": "a batch's logged cells, written before they are applied",
    "model[hydrology]._work[2]": "a batch's logged height changes, written before they are applied",
    "model[hydrology]._work[3]": "a batch's budget rows, written before they are applied",
    "model[hydrology].stamp": "neighbour marks of a lake rebuild, reset at its start",
    "model[hydrology].n_lakes": "the lake count of the last rebuild, written and never read (hs holds the count)",
    "*.eroder.dz": "the eroder's output buffer, written in full at each coupling",
    "*.eroder.e_area": "the eroder's exchange buffer, written in full at each coupling",
    "*.eroder.held": "sediment per node, recounted from the particles at each coupling",
}


def _matches(path: str, pattern: str) -> bool:
    """``pattern`` with ``*`` for any text (everything else literal) matches all of ``path``."""
    return re.fullmatch(".*".join(map(re.escape, pattern.split("*"))), path) is not None


def _ignored(path: str) -> bool:
    return any(_matches(path, pattern) for pattern in IGNORED)


def _same_number(a, b) -> bool:
    if isinstance(a, (float, np.floating)) and math.isnan(a):
        return isinstance(b, (float, np.floating)) and math.isnan(b)
    return bool(a == b)


def _attributes(obj) -> dict:
    attrs = getattr(obj, "__dict__", {})
    attrs = dict(attrs) if isinstance(attrs, dict) else {}
    for slot in getattr(type(obj), "__slots__", ()):
        if hasattr(obj, slot):
            attrs[slot] = getattr(obj, slot)
    if isinstance(attrs.get("nbr"), np.ndarray) and isinstance(attrs.get("start"), np.ndarray) and "state" in attrs:
        attrs["nbr"] = attrs["nbr"][: int(attrs["start"][attrs["state"].n])]  # the lists' used part
    return attrs


def compare(a, b, path: str, out: list[str], seen: set, depth: int = 0) -> None:
    """Append to ``out`` the paths under ``path`` where ``a`` and ``b`` differ (``IGNORED`` aside)."""
    key = (id(a), id(b))
    if key in seen or depth > 12 or _ignored(path):
        return
    seen.add(key)
    real = (float, np.floating)
    whole = (int, np.integer)
    if (isinstance(a, real) and isinstance(b, real)) or (isinstance(a, whole) and isinstance(b, whole)):
        if not isinstance(a, bool) and not isinstance(b, bool):  # a NumPy scalar equals its Python value
            if not _same_number(a, b):
                out.append(f"{path}: {a!r} vs {b!r}")
            return
    if type(a) is not type(b):
        out.append(f"{path}: {type(a).__name__} vs {type(b).__name__}")
        return
    if isinstance(a, FunctionType):  # a closure's variables are state too (a counter in a list, say)
        cells = zip(a.__closure__ or (), b.__closure__ or (), strict=False)
        for name, (x, y) in zip(a.__code__.co_freevars, cells, strict=False):
            try:
                compare(x.cell_contents, y.cell_contents, f"{path}<{name}>", out, seen, depth + 1)
            except ValueError:  # an empty cell
                continue
        return
    if isinstance(a, MethodType):
        compare(a.__self__, b.__self__, f"{path}.__self__", out, seen, depth + 1)
        return
    if isinstance(a, (BuiltinFunctionType, ModuleType, type)):
        return
    if isinstance(a, np.ndarray):
        if a.shape != b.shape or a.dtype != b.dtype:
            out.append(f"{path}: shape/dtype {a.shape}{a.dtype} vs {b.shape}{b.dtype}")
        elif a.dtype.kind == "O":
            for i, (x, y) in enumerate(zip(a.ravel(), b.ravel(), strict=True)):
                compare(x, y, f"{path}[{i}]", out, seen, depth + 1)
        elif not np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"):
            out.append(f"{path}: {int((a != b).sum())} of {a.size} values")
        return
    if isinstance(a, (bool, complex, str, bytes, type(None), np.generic, Path)):
        if not (a == b):
            out.append(f"{path}: {a!r} vs {b!r}")
        return
    if isinstance(a, (list, tuple)):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} vs {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            compare(x, y, f"{path}[{i}]", out, seen, depth + 1)
        return
    if isinstance(a, dict):
        if set(a) != set(b):
            out.append(f"{path}: keys {sorted(map(str, set(a) ^ set(b)))}")
            return
        for k in a:
            compare(a[k], b[k], f"{path}[{k!r}]", out, seen, depth + 1)
        return
    if isinstance(a, np.random.Generator):
        compare(a.bit_generator.state, b.bit_generator.state, f"{path}.rng", out, seen, depth + 1)
        return
    if type(a).__module__.split(".")[0] in ("numba", "llvmlite", "matplotlib", "threading"):
        return  # compiled kernels, figures, locks: no run state
    attrs, battrs = _attributes(a), _attributes(b)
    for k in sorted(set(attrs) | set(battrs)):
        if k in ("out", "started", "resumed") or _ignored(f"{path}.{k}"):  # the run folder, the session
            continue
        if k not in attrs or k not in battrs:
            out.append(f"{path}.{k}: set on one side only")
            continue
        compare(attrs[k], battrs[k], f"{path}.{k}", out, seen, depth + 1)


def build(name: str, sets: list[str], folder: Path, *, resume: bool):
    """The run's :class:`Simulation` as ``erosim run`` builds it (quiet), into ``folder``."""
    from erosim.io.runfolder import RunFolder
    from erosim.scenarios import kinds, loader
    from erosim.simulation.simulation import Simulation

    scenario = loader.load(name, sets)
    out = RunFolder(folder, resume=resume, overwrite=not resume)
    setup = kinds.resolve(kinds.get(scenario.kind).builder)(scenario, out)
    sim = Simulation(
        setup.models, out=out, stop_time=setup.stop_time, callbacks=setup.callbacks, kind=scenario.kind,
        label=scenario.name, unit=setup.unit, checkpoint_wall_s=setup.checkpoint_wall_s, progress=False,
    )  # fmt: skip
    return sim


def audit(name: str, sets: list[str], iterations: int, folder: Path) -> list[str]:
    """Differences between a run after ``iterations`` iterations and its restored checkpoint."""
    sim = build(name, sets, folder, resume=False)
    sim.status = "running"
    sim._fire()
    for _ in range(iterations):
        if sim.done():
            break
        sim._step()
        sim._fire()
    sim.checkpoint()
    again = build(name, sets, folder, resume=True)
    again.restore()
    out: list[str] = []
    seen: set = set()
    compare(sim.iteration, again.iteration, "iteration", out, seen)
    for a, b in zip(sim.models, again.models, strict=True):
        compare(a, b, f"model[{a.name}]", out, seen)
    for a, b in zip(sim.callbacks, again.callbacks, strict=True):
        compare(a, b, f"callback[{a.name}]", out, seen)
    return out


if __name__ == "__main__":
    import sys
    import tempfile

    name, n, *sets = sys.argv[1:]
    with tempfile.TemporaryDirectory() as tmp:
        for line in audit(name, sets, int(n), Path(tmp) / "run"):
            print(line)
