"""The motion manifold (paper 2): pose features, PCA, SOM, GRBF, clustering, mixtures, the
Markov model and the primitive model that generates motion through the guards (C:
``libmlayer/manifold``, ``libmlayer/generate``).

Layer 6 of the package: imports the base modules and the layers below (model, io, layers,
guards, pipeline).
"""
