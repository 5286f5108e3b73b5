"""The motion model: :class:`~mlayer.Motion` and its skeleton, quaternions, length units, the
up axis, trimming, mirroring and root motion (C: ``libmlayer/motion``, ``libmlayer/math``).

Layer 1 of the package (docs/ARCHITECTURE.md, "The Python package"): imports only the base
modules of ``mlayer`` (``errors`` and the private ``_*.py``). Re-exports nothing: the public names
are those of ``mlayer``.
"""
