"""What a batch run reports: one record per output (the columns of :data:`FIELDS`), the
:class:`BatchResult` with its summary table and its CSV or JSON report, and the progress bar
over clips."""
from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
from typing import Any

import numpy as np

from .._files import atomic_output

__all__ = ["BatchResult", "FIELDS", "STATUS_OK", "STATUS_SKIPPED", "STATUS_FAILED",
           "STATUS_LINK"]

STATUS_OK, STATUS_SKIPPED, STATUS_FAILED = "ok", "skipped", "failed"
#: records of symbolic links that were not read as clips (links to folders, dangling links);
#: the record's error field says which and whether it was followed
STATUS_LINK = "link"

#: report columns, in order
FIELDS = ("input", "output", "variant", "status", "error", "frames", "frames_out", "fps",
          "seconds", "jitter_before", "jitter_after", "sliding_before", "sliding_after",
          "worker")


@dataclasses.dataclass(frozen=True)
class BatchResult:
    """What :func:`mlayer.batch` did (read-only: a report of a run).

    Attributes
    ----------
    operation : str
        The operation's name.
    records : list of dict
        One record per output (dicts with the keys of :data:`FIELDS`), in input order, then
        one record per symbolic link that was not read as a clip (status ``"link"``: a link
        to a folder or a dangling link, its note in ``error``).
    seconds : float
        The wall time.
    n_workers : int
        Dask workers.
    scheduler : str
        The scheduler's address (empty for the embedded cluster).
    """
    operation: str
    records: list[dict[str, Any]]
    seconds: float
    n_workers: int = 0
    scheduler: str = ""

    def count(self, status: str) -> int:
        """The number of records of a status.

        Parameters
        ----------
        status : str
            :data:`STATUS_OK`, :data:`STATUS_SKIPPED`, :data:`STATUS_FAILED` or
            :data:`STATUS_LINK`.

        Returns
        -------
        int
            The count.
        """
        return sum(1 for r in self.records if r["status"] == status)

    @property
    def outputs(self) -> list[dict[str, Any]]:
        """The records of outputs (without the link records)."""
        return [r for r in self.records if r["status"] != STATUS_LINK]

    @property
    def links(self) -> int:
        """Records of symbolic links not read as clips."""
        return self.count(STATUS_LINK)

    @property
    def ok(self) -> int:
        """Outputs done by this run."""
        return self.count(STATUS_OK)

    @property
    def skipped(self) -> int:
        """Outputs up to date from an earlier run (skipped)."""
        return self.count(STATUS_SKIPPED)

    @property
    def failed(self) -> int:
        """Outputs that failed."""
        return self.count(STATUS_FAILED)

    @property
    def exit_code(self) -> int:
        """0 when every output is done (now or by an earlier run), 1 when any failed."""
        return 1 if self.failed else 0

    def table(self) -> str:
        """A summary table.

        Returns
        -------
        str
            One line per output, the failures and links, then the totals.
        """
        def f(x: Any, fmt: str = "{:.3g}") -> str:
            return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) \
                else fmt.format(x)
        rows = []
        for r in self.records:
            name = os.path.basename(r.get("output") or r["input"])
            rows.append((name, r["status"], f(r.get("frames"), "{:d}"),
                         f(r.get("seconds"), "{:.2f}"),
                         f"{f(r.get('jitter_before'))} -> {f(r.get('jitter_after'))}",
                         f"{f(r.get('sliding_before'))} -> {f(r.get('sliding_after'))}"))
        head = ("output", "status", "frames", "s", "jitter (h/s^3)", "foot sliding (h/s)")
        w = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
        line = "  ".join
        out = [line(h.ljust(w[k]) for k, h in enumerate(head))]
        out += [line(str(x).ljust(w[k]) for k, x in enumerate(row)) for row in rows]
        for r in self.records:
            if r["status"] == STATUS_FAILED:
                out.append(f"FAILED {r['input']}: {r.get('error', '')}")
            elif r["status"] == STATUS_LINK:
                out.append(f"LINK {r['input']}: {r.get('error', '')}")
        done = [r for r in self.records if r["status"] == STATUS_OK]
        clips = len({r["input"] for r in done})
        busy = sum({r["input"]: r.get("seconds") or 0.0 for r in done}.values())
        out.append(f"{self.operation}: {len(self.outputs)} outputs: {self.ok} done, "
                   f"{self.skipped} up to date (skipped), {self.failed} failed; "
                   f"{clips} clips in {self.seconds:.2f} s wall "
                   f"({busy:.2f} s in tasks, {self.n_workers} workers)")
        return "\n".join(out)

    def write_report(self, path: str | os.PathLike[str]) -> None:
        """Write the records as JSON or CSV, atomically.

        Parameters
        ----------
        path : str or os.PathLike
            ``.json``: ``{"operation", "seconds", "n_workers", "scheduler", "summary",
            "records"}``; CSV for any other extension.
        """
        path = os.fspath(path)
        if path.lower().endswith(".json"):
            doc = {"operation": self.operation, "seconds": self.seconds,
                   "n_workers": self.n_workers, "scheduler": self.scheduler,
                   "summary": {"outputs": len(self.outputs), "ok": self.ok,
                               "skipped": self.skipped, "failed": self.failed,
                               "links": self.links},
                   "records": self.records}
            text = json.dumps(doc, indent=1, default=_json_default)
        else:
            buf = io.StringIO()
            w = csv.DictWriter(buf, fieldnames=FIELDS, extrasaction="ignore")
            w.writeheader()
            for r in self.records:
                w.writerow({k: (json.dumps(v) if k == "variant" else v)
                            for k, v in r.items()})
            text = buf.getvalue()
        parent = os.path.dirname(os.path.abspath(path))
        os.makedirs(parent, exist_ok=True)
        with atomic_output(path) as tmp:
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                f.write(text)


def _json_default(o: Any) -> Any:
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)
