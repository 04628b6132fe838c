"""Compute devices of the SPH step: ``cpu`` (Numba, always) and ``cuda`` (numba-cuda, optional).

The CUDA path needs an NVIDIA GPU with its driver and the ``numba-cuda`` package (``pip install
'erosim[cuda]'``). With ``NUMBA_ENABLE_CUDASIM=1`` Numba's CUDA simulator stands in for the GPU: the
same kernels run as Python on the CPU — correct, very slow, for tests only.

numba-cuda releases built before numpy 2.5 register an overload of ``np.row_stack`` when the first
kernel compiles; numpy 2.5 removed that alias of ``np.vstack`` (deprecated since 2.0), and every
compile then fails with AttributeError (seen on a CUDA image with numpy 2.5.2). :func:`numpy_aliases`
puts the alias back, naming the function it always named, only where numpy lacks it, before
numba-cuda is imported.
"""

from __future__ import annotations

import os

from erosim.core.errors import ConfigError

DEVICES = ("cpu", "cuda")


def simulator() -> bool:
    """Whether Numba's CUDA simulator is switched on (``NUMBA_ENABLE_CUDASIM=1``)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0")


def numpy_aliases() -> None:
    """Restore ``np.row_stack`` (= ``np.vstack``) where numpy ≥ 2.5 removed it (module docstring)."""
    import numpy as np

    if "row_stack" not in vars(np):
        np.row_stack = np.vstack


def cuda_status() -> tuple[bool, str]:
    """(usable, what): whether ``--device cuda`` can run here, and the GPU or the reason in words."""
    numpy_aliases()
    if simulator():
        return True, "Numba CUDA simulator (NUMBA_ENABLE_CUDASIM=1: the kernels run as Python, for tests)"
    try:
        from numba import cuda
    except Exception as exc:  # a broken numba-cuda install must not break `erosim info`
        return False, f"numba.cuda cannot be imported ({type(exc).__name__}: {exc})"
    try:
        usable = bool(cuda.is_available())
    except Exception:
        usable = False
    if not usable:
        return False, "no CUDA driver or NVIDIA GPU found"
    try:
        dev = cuda.get_current_device()
        name = dev.name.decode() if isinstance(dev.name, bytes) else str(dev.name)
        cc = ".".join(str(x) for x in dev.compute_capability)
        impl = getattr(cuda, "implementation", "Built-in")
        return True, f"{name} (compute capability {cc}; numba.cuda: {impl})"
    except Exception as exc:
        return False, f"the CUDA driver is there but no GPU could be opened ({type(exc).__name__}: {exc})"


def require(device: str) -> None:
    """Raise a one-sentence :class:`ConfigError` when ``device`` cannot run on this machine."""
    if device not in DEVICES:
        raise ConfigError(f"Unknown device '{device}'; use one of: {', '.join(DEVICES)}.")
    if device == "cuda":
        ok, what = cuda_status()
        if not ok:
            raise ConfigError(
                f"Device 'cuda' is not usable on this machine ({what}); run with --device cpu (the default), "
                "or on a machine with an NVIDIA GPU and `pip install 'erosim[cuda]'`."
            )


def available() -> dict[str, str]:
    """Every device and whether it is usable here, in words (for ``erosim info``)."""
    ok, what = cuda_status()
    return {"cpu": "usable (Numba)", "cuda": ("usable: " if ok else "not usable: ") + what}
