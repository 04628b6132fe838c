"""The `sph-terrain` kind: SPH water eroding a heightmap (seed 000, SPEC HM-, ER-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
