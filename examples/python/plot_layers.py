"""Plot a clip's layers (paper 1, Figures 1 and 2) and save them as .npz for analysis.

    python examples/python/plot_layers.py [CLIP.bvh] [--out DIR]

Needs matplotlib (``pip install 'mlayer[plot]'``). The figure is returned as a
matplotlib Figure, so it can also be shown or edited; the backend is left alone.
"""
from __future__ import annotations

import mlayer
import mlayer.plotting.plot
from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    m = mlayer.read_bvh(args.input)
    layers = mlayer.decompose(m)
    joint, axis = mlayer.plotting.plot.layer_choice(m, layers)
    fig = mlayer.plotting.plot.plot_layers(m, layers, args.out / "layers.png")
    layers.save_npz(args.out / "layers.npz")
    print(f"{len(fig.axes)} panels: the root's {'XYZ'[axis]} translation and {joint}; "
          f"base smoothing per joint (lam) {layers.lam.min():.3g} .. {layers.lam.max():.3g}")
    print(f"wrote {args.out / 'layers.png'} and {args.out / 'layers.npz'}")


if __name__ == "__main__":
    main()
