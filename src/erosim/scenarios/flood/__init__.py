"""The `flood` kind: a dam-break flood over a DEM with hazard maps (SPEC FL-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
