"""The `voxel` kind: SPH water eroding a voxel terrain by shear stress (seed 001, SPEC VX-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
