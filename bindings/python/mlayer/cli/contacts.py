"""`mlayer contacts IN.bvh [--joints A,B] [--plot contacts.png]`: foot contacts of a clip.

Prints, per contact point (ankle, toe or End Site), the number of contacts, the duty factor
(fraction of frames in contact) and the median contact length; --plot draws a timeline per
point (matplotlib: mlayer.plotting.plot.plot_contacts), written atomically.
"""
from __future__ import annotations

import numpy as np

from ..io.bvh import read_bvh
from ..guards.contacts import contact_intervals, detect_contacts
from ..plotting.plot import plot_contacts
from ._command import FIGURE, Needs, command


def _arguments(p) -> None:
    p.add_argument("input", metavar="IN.bvh")
    p.add_argument("--joints", default=None, metavar="A,B,...",
                   help="contact joints (default: feet found by name; 'Joint/End' for an "
                        "End Site)")
    p.add_argument("--plot", metavar="contacts.png", help="timeline per contact point")


@command("contacts", "detect foot contacts: counts, duty factors, optional timeline plot",
         arguments=_arguments, reads_clips=True, inputs=("input",), outputs={"plot": FIGURE},
         requires=(Needs("matplotlib", when="plot"),))
def cmd_contacts(args) -> int:
    m = read_bvh(args.input)
    names, c = detect_contacts(m, args.joints)
    print(f"{args.input}: {len(m)} frames at {m.fps:.6g} fps")
    width = max(len(n) for n in names)
    for i, n in enumerate(names):
        iv = contact_intervals(c[:, i])
        med = np.median([b - a for a, b in iv]) / m.fps if iv else 0.0
        print(f"  {n:<{width}}  {len(iv):4d} contacts  duty {c[:, i].mean():.2f}  "
              f"median {med:.2f} s")
    if args.plot:
        plot_contacts(names, c, m.fps, args.plot)
        print(f"  wrote {args.plot}")
    return 0
