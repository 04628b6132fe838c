"""The `splash` kind: drops and jets splashing wet ground (seed 003, SPEC SP-).

``schema`` reads the scenario file, ``build`` wires the run, ``outputs`` writes what it leaves.
"""
