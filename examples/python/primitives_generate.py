"""Learn motion primitives of a clip and generate new motion (paper 2).

    python examples/python/primitives_generate.py [CLIP.bvh] [--out DIR]

The model: pose features on a self-organizing map, a GRBF mapping back to poses, k-means
primitives and a Markov chain of their transitions. New motion follows the primitives from a
start frame, or a path through points picked on the map.
"""
from __future__ import annotations

import mlayer
from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    m = mlayer.read_bvh(args.input)
    # a small map and few epochs keep the example quick; `mlayer primitives` sizes them by
    # the number of frames
    model = mlayer.PrimitiveModel.fit(m, som=(16, 16), epochs=8, lattice=(8, 8), seed=0)
    model.save(args.out / "model.npz")
    print(f"{model.centers.shape[0]} primitives on a {model.som_codebook.shape[0]} x "
          f"{model.som_codebook.shape[1]} map")

    # the primitives' sequence from a start frame, sampled from a slightly perturbed chain
    walk = model.generate(240, start_frame=0, noise=0.05, seed=1)
    mlayer.write_bvh(walk, args.out / "generated.bvh")
    # a path through three points of the map (lattice coordinates: column, row)
    path = model.generate(120, through=[(2, 3), (12, 8), (6, 13)])
    mlayer.write_bvh(path, args.out / "through_points.bvh")
    print(f"generated {walk.n_frames} and {path.n_frames} frames; wrote {args.out}")


if __name__ == "__main__":
    main()
