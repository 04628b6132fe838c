"""Ensembles of runs on Dask (``erosim sweep``): a plan of members (:mod:`~erosim.sweep.design`,
:mod:`~erosim.sweep.plan`), each an ordinary run executed as a Dask task
(:mod:`~erosim.sweep.member`, :mod:`~erosim.sweep.dask_executor`), aggregated into probability maps
(:mod:`~erosim.sweep.aggregate`); :func:`erosim.sweep.runner.run_sweep` ties them together.
"""
