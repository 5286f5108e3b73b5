"""Figures (matplotlib) and renders (Pillow, imageio-ffmpeg) of motions, layers and manifolds.

Layer 7 of the package: imports the base modules and every library layer below it (model to
manifold); never imported by them.
"""
