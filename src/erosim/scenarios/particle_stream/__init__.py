"""The `particle-stream` kind: a particle stream cutting a canyon over a hardness map (seed 004, SPEC ST-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
