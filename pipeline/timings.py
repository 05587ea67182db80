"""Where a populate's time goes: one `{"key": "timing", ...}` record per part, in the trace and as a table.

A record names either a pass and one of its steps (pipeline.abstraction.passes times every step, with the model
work done in it: seconds inside the model backend, prompt tokens evaluated and restored, decodes, and
the reasoner's seconds), or a stage around the passes (`startup`, `ingest`, `model load`,
`population`, `SHACL`, `export`, `total`). Timings go to the trace and the `--timings` table only,
never into a prompt or the ontology.
"""
from __future__ import annotations

import json
import os
import time
from contextlib import contextmanager
from typing import Iterator, TextIO

# what a step record counts besides its wall time, in the order the table shows them, with their formats
_FORMATS = {"model_seconds": "9.1f", "tokens": "8,", "restored_tokens": "9,", "decodes": "8,", "reasoner_seconds": "11.1f"}
COUNTERS = tuple(_FORMATS)


class Timings:
    """Collects timing records; writes each to `trace` (a JSON-lines file) as it comes."""

    def __init__(self, trace: TextIO | None = None):
        self.trace = trace
        self.records: list[dict] = []

    def record(self, record: dict) -> None:
        record = {"key": "timing", **record}
        self.records.append(record)
        if self.trace is not None:
            self.trace.write(json.dumps(record) + "\n")

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the block as stage `name` (recorded even when it raises)."""
        started = time.perf_counter()
        try:
            yield
        finally:
            self.record({"stage": name, "seconds": round(time.perf_counter() - started, 4)})

    def seconds(self, stage: str) -> float:
        return sum(r["seconds"] for r in self.records if r.get("stage") == stage)

    def model_seconds(self) -> float:
        """Seconds of model work: loading it and running it (inside the backend's calls)."""
        return self.seconds("model load") + sum(r.get("model_seconds", 0.0) for r in self.records if "step" in r)

    def table(self) -> str:
        """The breakdown as text: stages, each pass's steps with their model work, subtotals, shares."""
        steps = [r for r in self.records if "step" in r]
        width = max([len(f"  {r['pass']}: {r['step']}") for r in steps] + [24]) + 1
        head = f"{'':{width}}{'seconds':>9}{'model s':>9}{'tokens':>8}{'restored':>9}{'decodes':>8}{'reasoner s':>11}"
        lines = ["time breakdown (wall seconds; model s: inside the model backend)", head]

        def row(label: str, seconds: float, counts: dict | None = None) -> str:
            counts = counts or {}
            return (f"{label:{width}}{seconds:9.1f}" + "".join(
                format(counts[c], spec) if c in counts else " " * int(spec.rstrip(",f").split(".")[0])
                for c, spec in _FORMATS.items())).rstrip()

        for stage in ("startup", "ingest", "model load"):
            if any(r.get("stage") == stage for r in self.records):
                lines.append(row(stage, self.seconds(stage), {"model_seconds": self.seconds(stage)}
                                 if stage == "model load" else None))
        for name in dict.fromkeys(r["pass"] for r in steps):
            mine = [r for r in steps if r["pass"] == name]
            for r in mine:
                lines.append(row(f"  {name}: {r['step']}", r["seconds"], {c: r[c] for c in COUNTERS if c in r}))
            sums = {c: sum(r.get(c, 0) for r in mine) for c in COUNTERS if any(c in r for r in mine)}
            lines.append(row(f"{name} pass", sum(r["seconds"] for r in mine), sums))
        for stage in ("population", "SHACL", "export"):
            if any(r.get("stage") == stage for r in self.records):
                lines.append(row(stage, self.seconds(stage)))
        total = self.seconds("total")
        if total:
            model = self.model_seconds()
            reasoner = sum(r.get("reasoner_seconds", 0.0) for r in steps)
            lines.append(row("total", total, {"model_seconds": model}))
            lines.append(f"model {model:.1f} s ({100 * model / total:.1f} %), reasoner {reasoner:.1f} s, "
                         f"everything else {total - model - reasoner:.1f} s; "
                         f"non-model share {100 * (total - model) / total:.1f} %")
        return "\n".join(lines)


def process_age() -> float:
    """Seconds since this process started (interpreter start-up and imports included), 0 where unknown."""
    try:
        with open("/proc/self/stat") as f:
            ticks = int(f.read().rpartition(")")[2].split()[19])
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(0.0, uptime - ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return 0.0
