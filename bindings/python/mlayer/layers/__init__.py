"""The linear Gaussian system and the layers: the LGS smoother, the decomposition and synthesis
of layers, alpha curves, the One Euro baseline (C: ``libmlayer/layers``, ``libmlayer/math``).

Layer 3 of the package: imports the base modules, :mod:`mlayer.model` and :mod:`mlayer.io`.
"""
