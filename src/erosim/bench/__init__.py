"""erosim.bench: the benchmarks behind `erosim bench …` (docs/performance.md)."""


def threading_layer() -> str | None:
    """The Numba threading layer the benchmark's parallel loops ran on (``omp``, ``workqueue``, ``tbb``), or None
    before any ran: figures differ by layer (docs/performance.md, "Threading layer")."""
    import numba

    try:
        return str(numba.threading_layer())
    except ValueError:
        return None
