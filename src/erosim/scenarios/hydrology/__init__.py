"""The `hydrology` kind: droplet hydrology with rivers and lakes (seed 002, SPEC HY-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
