"""`mlayer batch`: run an operation over a whole corpus in parallel (mlayer.batch): a local
process pool by default, a Dask cluster with --scheduler.

    mlayer batch denoise captures/ -o clean/
    mlayer batch stylize 'cmu/**/*.bvh' -o augmented/ --alphas 0.5:2.5:0.5 --report report.json
    mlayer batch resample captures/ -o at30/ --fps 30 --scheduler tcp://10.0.0.5:8786

Shows a progress bar over clips on stderr when it is a terminal (tqdm; --no-progress: none),
then a summary table (status, frames, seconds,
jitter and foot sliding before -> after per output). Exit status 0 when every output is done
(now or by an earlier run: outputs up to date are skipped), 1 when any clip failed (the others
are still done), 2 on a usage error.
"""
from __future__ import annotations

import sys

from ..batching import batch, operations, parse_alphas
from ..errors import InvalidArgumentError
from ._command import FOLDER, Needs, Output, command
from .layers import parse_joint_alphas


def _arguments(p) -> None:
    ops = operations()
    p.add_argument("operation", choices=sorted(ops), metavar="OPERATION",
                   help="; ".join(f"{k}: {v.help}" for k, v in sorted(ops.items())))
    p.add_argument("inputs", nargs="+", metavar="INPUT_DIR_OR_GLOB",
                   help="a folder (every .bvh below it), a quoted glob ('cmu/**/*.bvh') or files")
    p.add_argument("-o", "--output-dir", required=True, metavar="OUT_DIR")
    p.add_argument("--alpha", type=float, action="append",
                   help="stylize: an alpha (repeatable: one output per alpha; default 2)")
    p.add_argument("--alphas", metavar="START:STOP:STEP",
                   help="stylize: a range of alphas, STOP included (e.g. 0.5:2.5:0.5), or a "
                        "list 1,1.5,2")
    p.add_argument("--joint", action="append", metavar="PATTERN=ALPHA",
                   help="stylize: alpha for the joints matching a name or glob (repeatable)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a Dask cluster: its scheduler (tls://host:8786, tcp://...), or "
                        "'dask' for an embedded LocalCluster (default: a local process pool, "
                        "no Dask)")
    p.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local pool or the embedded cluster (default: "
                        "one per CPU)")
    p.add_argument("--report", metavar="REPORT.json|csv",
                   help="per-output records as JSON (.json) or CSV")
    p.add_argument("--force", action="store_true", help="redo outputs that are up to date")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-metrics", action="store_true",
                   help="skip the jitter and foot-sliding figures (a little faster)")
    p.add_argument("--no-keep-contacts", "--no-contacts", dest="no_contacts", action="store_true",
                   help="denoise/stylize: do not pin the feet during detected contacts")
    g = p.add_argument_group("layer options (denoise, stylize, features)")
    g.add_argument("--gamma", type=float, help="base-layer largest displacement angle, radians")
    g.add_argument("--lam-c", type=float, help="control-layer lambda (default: GCV)")
    g.add_argument("--sigma-c", type=float, help="control-layer sigma (default: GCV)")
    g = p.add_argument_group("resampling options (resample, timewarp)")
    g.add_argument("--fps", type=float, help="resample: the new frame rate")
    g.add_argument("--n-frames", type=int, help="resample/timewarp: the new frame count")
    g.add_argument("--strength", type=float, help="timewarp: 0 uniform, 1 natural (default)")
    g.add_argument("--lam", type=float, help="resample/timewarp: LGS smoothness (default auto)")


@command("batch", "run denoise, stylize, features, resample or timewarp over a corpus in parallel",
         arguments=_arguments, reads_clips=True, inputs=("inputs",),
         outputs={"output_dir": FOLDER,
                  "report": Output((".json", ".csv"), "a JSON or CSV report", makes_dirs=True)},
         requires=(Needs("distributed", when=lambda a: a.scheduler is not None,
                         feature="mlayer batch --scheduler"),
                   Needs("cryptography", when=lambda a: a.scheduler == "dask",
                         feature="mlayer batch's embedded Dask cluster (TLS)")))
def cmd_batch(args) -> int:
    options = {}
    for name in ("gamma", "lam_c", "sigma_c", "fps", "n_frames", "strength", "lam"):
        v = getattr(args, name)
        if v is not None:
            options[name] = v
    if args.no_contacts:
        options["keep_contacts"] = False
    if args.joint:
        options["joints"] = parse_joint_alphas(args.joint)
        if any(not isinstance(v, float) for v in options["joints"].values()):
            raise InvalidArgumentError("--joint: alpha keys over time (PATTERN=T:A,...) are "
                                       "for mlayer stylize; batch takes PATTERN=ALPHA")
    alphas = None
    if args.alpha or args.alphas:
        alphas = list(args.alpha or []) + (parse_alphas(args.alphas) if args.alphas else [])
    if args.workers is not None and args.workers < 1:
        raise InvalidArgumentError(f"--workers must be >= 1, got {args.workers}")
    # the reading options of every command that reads clips (_command adds them), passed to the
    # workers: a context variable of this process does not reach them
    read = {"strict": True if args.strict else None,
            "up": None if args.up == "auto" else args.up, "trim": args.trim,
            "units": args.units}
    result = batch(args.operation, args.inputs, args.output_dir, alphas=alphas, read=read,
                   scheduler=args.scheduler, n_workers=args.workers, report=args.report,
                   progress=False if args.no_progress else None, force=args.force,
                   metrics=not args.no_metrics, **options)
    print(result.table())
    if args.report:
        print(f"wrote {args.report}")
    if result.failed:
        print(f"mlayer batch: {result.failed} of {len(result.outputs)} outputs failed",
              file=sys.stderr)
    return result.exit_code
