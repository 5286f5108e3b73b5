"""Stylize per body part: exaggerate the arms, calm the legs, keep the feet on the floor.

    python examples/python/stylize_body_parts.py [CLIP.bvh] [--out DIR]

``joints`` maps joint names or globs to their own alpha (the controllable layer's scale);
every other joint takes ``alpha``. The guards (joint limits when some alpha > 1, the foot
contacts, the floor) keep the result within what a body can do; the report says what they did.
"""
from __future__ import annotations

import mlayer
from _common import arguments

# CMU names; other rigs name their joints otherwise (mlayer info CLIP.bvh lists them)
ARMS = {"*Shoulder": 2.5, "*Elbow": 2.5, "*Wrist": 2.0}
LEGS = {"*Hip": 0.5, "*Knee": 0.5}


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    m = mlayer.read_bvh(args.input)
    for name, alpha, joints in [("arms", 1.0, ARMS), ("legs_calm", 1.0, LEGS),
                                ("all_bold", 2.0, None)]:
        out, report = mlayer.stylize(m, alpha, joints, return_report=True)
        mlayer.write_bvh(out, args.out / f"{name}.bvh")
        print(f"{name}: alpha {alpha}, joints {joints or {}}; limits ran: "
              f"{report.limits_applied}, {len(report.limited)} joints limited, feet pinned on "
              f"{report.contact_frames} frames, floor at {report.floor_height:.2f}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
