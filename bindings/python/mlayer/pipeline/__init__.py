"""The compositions over layers and guards: denoise / stylize and the clip they run on, retiming,
retargeting, streaming (C: ``libmlayer/pipeline``, ``retarget``, ``stream``).

Layer 5 of the package: imports the base modules and the layers below (model, io, layers,
guards).
"""
