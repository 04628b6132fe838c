"""Compile every CUDA kernel of the SPH device path to PTX, without a GPU.

The CUDA simulator (the test suite's check of the device path) runs the kernels as Python, so it
cannot see what only the real compiler rejects (typing, shared memory, atomics on float64). This
script compiles each kernel of :mod:`erosim.sph.kernels_cuda` for its real argument types — both
precisions, 2-D and 3-D, every variant of the fused pass — and each of :mod:`erosim.sph.kernels_swe_cuda`
(the shallow-water step, float64) with numba-cuda's ``compile_ptx``, which
needs NVVM (the ``nvidia-cuda-nvcc-cu12`` wheel) but no driver and no GPU.

    pip install 'erosim[cuda]'          # numba-cuda and the CUDA toolkit wheels
    python benchmarks/cuda_compile_check.py [--cc 9.0]

Prints one line per kernel and exits non-zero if any fails to compile.
"""

from __future__ import annotations

import argparse
import itertools
import sys


def signatures(dtype: str, dim: int):
    """(name, python function, argument types) of every kernel for one precision and dimension."""
    from numba import boolean, float32, float64, int32, int64

    from erosim.sph import kernels_cuda as kc

    f = {"float64": float64, "float32": float32}[dtype]
    A2, A1 = f[:, :], f[:]
    I1, D1 = int64[:], float64[:]
    out = [
        ("bounds", kc.bounds, (A2, int64, D1, D1)),
        ("max_displacement", kc.max_displacement, (A2, A2, int64, D1)),
        ("_scan_blocks", kc._scan_blocks, (I1, int64, I1, I1)),
        ("_add_block_offsets", kc._add_block_offsets, (I1, int64, I1)),
        ("_set_first_zero", kc._set_first_zero, (I1,)),
        ("zero", kc.zero, (I1, int64)),
        ("zero(float)", kc.zero, (D1, int64)),
        ("cell_ids", kc.cell_ids, (A2, int64, D1, float64, I1, I1, I1)),
        ("scatter", kc.scatter, (I1, int64, I1, I1, I1)),
        ("sort_ranges", kc.sort_ranges, (I1, int64, I1)),
        ("fluid_flags", kc.fluid_flags, (I1, int64, int64, I1)),
        ("fluid_permutation", kc.fluid_permutation, (I1, int64, int64, I1, I1)),
        ("gather_rows", kc.gather_rows, (A2, A2, I1, int64, int64)),
        ("gather(float)", kc.gather, (A1, A1, I1, int64, int64)),
        ("gather(int)", kc.gather, (I1, I1, I1, int64, int64)),
        ("gather_sorted", kc.gather_sorted, (A2, I1, int64, A2)),
        ("copy_rows", kc.copy_rows, (A2, A2, int64)),
        ("count_lists", kc.count_lists, (A2, A2, int64, int64, int64, I1, I1, I1, I1, float64, I1, I1)),
        ("fluid_offsets", kc.fluid_offsets, (I1, I1, int64, I1)),
        ("boundary_offsets", kc.boundary_offsets, (I1, int64, int64, I1, I1)),
        ("fill_lists", kc.fill_lists, (A2, A2, int64, int64, int64, I1, I1, I1, I1, float64, I1, I1, int32[:])),
        ("sort_boundary_lists", kc.sort_boundary_lists, (I1, int64, int64, int32[:])),
        ("kick_drift", kc.kick_drift, (A2, A2, A2, A1, A1, A1, A1, int64) + (float64,) * 7),
        ("correct", kc.correct, (A2, A2, A1, A1, A1, A1, int64) + (float64,) * 7 + (D1,)),
        ("reflect", kc.reflect, (A2, A2, int64, A1, A1, A2, A2)),
        (
            "boundary_update_density",
            kc.boundary_update_density,
            (A1, A1, A1, A1, I1, int64, int64) + (float64,) * 5 + (boolean,),
        ),
    ]
    for kernel in ("wendland", "muller"):
        out.append(
            (
                f"boundary_density_rate[{kernel}]",
                kc.boundary_density_rate(dim, kernel),
                (A2, A2, I1, I1, int32[:], int64, int64, float64, float64, A1),
            )
        )
    variants = itertools.product(("wendland", "muller"), ("wcsph", "symmetric"), ("artificial", "laminar"))
    for kernel, form, visc in variants:
        out.append(
            (
                f"fluid_pass[{kernel},{form},{visc}]",
                kc.fluid_pass(dim, kernel, form, visc),
                (A2, A2, A1, A1, I1, I1, int32[:], int64) + (float64,) * 11 + (A2, A1, D1, int64),
            )
        )
    return out


def swe_signatures():
    """(name, python function, argument types) of every shallow-water kernel (float64, 2-D)."""
    from numba import boolean, float64, int64

    from erosim.sph import kernels_swe_cuda as ks

    A2, D1, I1, G = float64[:, :], float64[:], int64[:], float64[:, :]
    f, i = float64, int64
    return [
        ("swe.cell_ids", ks.cell_ids, (A2, i, f, f, f, i, i, I1, I1)),
        ("swe.pairs", ks.pairs, (A2, D1, i, f, f, f, i, i, I1, I1, I1, I1, I1, boolean)),
        ("swe.scaled_copy", ks.scaled_copy, (D1, D1, f, i)),
        ("swe.copy1", ks.copy1, (D1, D1, i)),
        ("swe.raise_to", ks.raise_to, (D1, D1, i)),
        ("swe.max1", ks.max1, (D1, i, D1)),
        ("swe.max_moved", ks.max_moved, (A2, A2, i, D1)),
        ("swe.lists_broken", ks.lists_broken, (A2, A2, D1, D1, i, D1, I1)),
        ("swe.depth_and_support", ks.depth_and_support, (A2, D1, D1, i, I1, I1, D1, f, f, f, i, D1, D1)),
        ("swe.accelerations", ks.accelerations, (A2, A2, D1, D1, D1, D1, i, I1, I1, G, f, f, f, A2)),
        ("swe.kick", ks.kick, (A2, A2, D1, G, f, A2, i, f, f, f)),
        ("swe.drift", ks.drift, (A2, A2, i, f, f, boolean[:, :]) + (boolean,) * 4 + (boolean[:], I1, I1)),
        ("swe.hold_contacts", ks.hold_contacts, (A2, i, I1, I1)),
        ("swe.cfl_limit", ks.cfl_limit, (A2, D1, D1, i, f, D1)),
        ("swe.surfaces", ks.surfaces, (A2, D1, G, i, f, D1)),
        (
            "swe.grid_maxima",
            ks.grid_maxima,
            (A2, A2, D1, D1, D1, D1, G, f, f, f, f, i, i, I1, I1, i, i, i, i, f, f, G, G, G, G, boolean[:, :], G, f),
        ),
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cc", default="9.0", help="compute capability to compile for (default 9.0: H100/H200)")
    args = ap.parse_args(argv)
    from numba import cuda

    cc = tuple(int(x) for x in args.cc.split("."))
    print(f"numba.cuda: {getattr(cuda, 'implementation', 'Built-in')}; compiling for sm_{cc[0]}{cc[1]}")
    jobs = {}  # (name, precision, dimension) → (kernel, argument types), each compiled once
    for dtype, dim in itertools.product(("float64", "float32"), (2, 3)):
        for name, kernel, sig in signatures(dtype, dim):
            key = (name, dtype, dim if name.startswith(("fluid_pass", "boundary_density_rate")) else 0)
            jobs.setdefault(key, (kernel, sig))
    for name, kernel, sig in swe_signatures():
        jobs[(name, "float64", 2)] = (kernel, sig)
    failed = 0
    for (name, dtype, dim), (kernel, sig) in jobs.items():
        what = f"{name} {dtype}" + (f" {dim}-D" if dim else "")
        try:
            ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=cc)
            print(f"ok    {what} ({len(ptx)} bytes of PTX)")
        except Exception as exc:  # report every failure, then exit non-zero
            failed += 1
            print(f"FAIL  {what}: {type(exc).__name__}: {str(exc).splitlines()[0][:300]}")
    print(f"{len(jobs) - failed} compiled, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
