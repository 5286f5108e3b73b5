"""`mlayer view CLIP.bvh [MORE.bvh ...] [--port N] [--host H] [--open]`: the interactive viewer.

Starts a local web server (127.0.0.1, a free port unless --port) serving a page that plays the
original and the processed motion as stick figures, with sliders for alpha (global and per
body part), denoising, contact cleanup and retiming; prints the address and serves until
Ctrl-C. Opens a browser only with --open. A clip that fails to parse is reported here and on
the page; the others are served.

Limits: --max-values (the output of one request, frames x points), --cache-mb (the result
cache), --manifold-frames (the training frames of the motion manifold panel), --threads (the
worker pool), --timeout (idle, slow and non-reading connections), --max-connections; --rename
joins clips of another joint naming scheme for the manifold's training. The API needs the
session token of the page and refuses other sites (see mlayer.viewer.server).
"""
from __future__ import annotations

import sys

from ..errors import InvalidArgumentError
from ..viewer import is_loopback, make_server
from ..viewer.server import (DEFAULT_CACHE_BYTES, DEFAULT_MANIFOLD_FRAMES, DEFAULT_MAX_CONNECTIONS,
                             DEFAULT_MAX_VALUES, DEFAULT_THREADS, DEFAULT_TIMEOUT)
from ._command import add_rename_option, command, parse_rename


def _arguments(p) -> None:
    p.add_argument("inputs", nargs="+", metavar="CLIP.bvh")
    p.add_argument("--port", type=int, default=0,
                   help="port to listen on (default: a free port)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1; anything but loopback exposes "
                        "the clips to the network)")
    p.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                   help="a further host name (or name:port) the page may be requested under "
                        "(repeatable); served without it: the bound address, the loopback "
                        "names, and on 0.0.0.0 or :: this machine's name and addresses; any "
                        "other Host header is refused (DNS rebinding)")
    p.add_argument("--open", action="store_true", help="open the page in a web browser")
    p.add_argument("--max-values", type=int, default=DEFAULT_MAX_VALUES, metavar="N",
                   help="the most output one request may produce, in frames x points (joints "
                        "and End Sites), checked before any work; longer lengths or higher "
                        "fps are refused with 413 (default %(default)s; a clip is always "
                        "served at its own size)")
    p.add_argument("--cache-mb", type=float, default=DEFAULT_CACHE_BYTES / 2**20, metavar="MB",
                   help="memory for cached results (processed motions and answers), least "
                        "recently used dropped first (default %(default)g)")
    p.add_argument("--threads", type=int, default=DEFAULT_THREADS, metavar="N",
                   help="worker threads serving requests, whatever the number of connections "
                        "(default %(default)s)")
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT, metavar="SECONDS",
                   help="a request must arrive whole within this many seconds of the "
                        "connect or of the previous answer, and an answer must be taken "
                        "whole within it, or the connection is closed (default %(default)g). "
                        "Every /api/ request needs the page's session token; requests from "
                        "other sites are refused")
    p.add_argument("--max-connections", type=int, default=DEFAULT_MAX_CONNECTIONS, metavar="N",
                   help="connections open at once; one more is answered 503 and closed "
                        "(default %(default)s)")
    p.add_argument("--manifold-frames", type=int, default=DEFAULT_MANIFOLD_FRAMES, metavar="N",
                   help="the most training frames of the page's motion manifold (the clips "
                        "decimated by one stride; default %(default)s)")
    add_rename_option(p)


@command("view", "interactive viewer in the browser: alpha sliders, cleanup, retiming",
         arguments=_arguments, reads_clips=True, inputs=("inputs",))
def cmd_view(args) -> int:
    if not 0 <= args.port <= 65535:
        raise InvalidArgumentError(f"--port must be in 0..65535, got {args.port}")
    if not is_loopback(args.host):
        print(f"mlayer view: warning: serving on {args.host}, not on loopback: anyone who can "
              f"reach this address can view the clips and run computations on this machine",
              file=sys.stderr)
    if not (args.cache_mb >= 0 and args.cache_mb < 2**40):
        raise InvalidArgumentError(f"--cache-mb must be a number of MB >= 0, got {args.cache_mb}")
    server = make_server(args.inputs, args.host, args.port, max_values=args.max_values,
                         cache_bytes=int(args.cache_mb * 2**20), threads=args.threads,
                         timeout=args.timeout, manifold_frames=args.manifold_frames,
                         allow_hosts=args.allow_host, max_connections=args.max_connections,
                         rename=parse_rename(args.rename))
    good = [c for c in server.clips if c.ok]
    for c in server.clips:
        if not c.ok:
            print(f"mlayer view: error: {c.error}", file=sys.stderr)
    if not good:
        print("mlayer view: error: no clip could be loaded; the page shows the errors",
              file=sys.stderr)
    print(f"mlayer view: serving {len(good)} of {len(server.clips)} clip(s) at {server.url} "
          f"(Ctrl-C to stop)", flush=True)
    server.warm()
    if args.open:
        import webbrowser
        webbrowser.open(server.url)
    try:
        server.serve_forever(poll_interval=0.25)
    except KeyboardInterrupt:
        print("mlayer view: stopped", file=sys.stderr)
    finally:
        server.server_close()
    return 0
