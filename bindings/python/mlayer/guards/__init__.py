"""The guards: joint limits, contacts and their cleanup, leg IK, plausibility and the measures
used to check them (C: ``libmlayer/guards``).

Layer 4 of the package: imports the base modules and the layers below (model, io, layers).
"""
