"""Files: BVH, glTF 2.0, AMASS / SMPL (C: ``libmlayer/io``).

Layer 2 of the package: imports the base modules and :mod:`mlayer.model`. (The bundled sample
clip, :mod:`mlayer.data`, stays at the top of the package, over this layer.)
"""
