"""The `sph` kind: a weakly compressible SPH fluid in a box (seed 000 ch. 3, SPEC SPH-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
