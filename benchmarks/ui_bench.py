"""Server time to render the PR2 robot page (HTML: SVG tree, component table, review controls).

PR2 is populated with the hand-written scripted abstraction and body (tests/kb_fixtures.PR2_WHOLE, no
model) and three reviewers' corrections (one of a body part); the page is rendered N times through the Flask app (no network), and
the median and spread are printed beside the JSON route for the same robot. Target: <= 300 ms.

    .venv/bin/python -m benchmarks.ui_bench [--iterations 30]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from tests.kb_fixtures import PR2_WHOLE, make_app
from urdfkb.kb_server.corrections import Correction, new
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading.ingest import load_urdf

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "urdf"
HTML = {"Accept": "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"}


def timed(client, path: str, headers: dict, n: int) -> list[float]:
    out = []
    for _ in range(n):
        started = time.perf_counter()
        resp = client.get(path, headers=headers)
        out.append((time.perf_counter() - started) * 1000)
        assert resp.status_code == 200, resp.status_code
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=30)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(Path(tmp) / "kb.sqlite3")
        tree = load_urdf(SHARED / "pr2.urdf")
        store.replace_robot("pr2", tree, PR2_WHOLE)
        store.add_correction("pr2", Correction.new({"action": "reclassify", "links": ["head_mount_prosilica_optical_frame"],
                                                    "class": "StereoCamera"}, "bench"))
        store.add_correction("pr2", Correction.new({"action": "confirm", "links": ["base_laser_link"]}, "bench"))
        store.add_correction("pr2", new({"part": "l_arm", "action": "split", "at": "l_elbow_flex_joint"}))
        app, jobs = make_app(store)
        client = app.test_client()
        timed(client, "/robots/pr2", HTML, 3)  # warm: query parses, templates compiled
        rows = []
        for label, path, headers in (("robot page (HTML)", "/robots/pr2", HTML),
                                     ("robot JSON", "/robots/pr2", {"Accept": "application/json"}),
                                     ("index page (HTML)", "/", HTML)):
            ms = timed(client, path, headers, args.iterations)
            rows.append((label, statistics.median(ms), min(ms), max(ms)))
        size = len(client.get("/robots/pr2", headers=HTML).data)
        jobs.shutdown()
        store.close()
    print(f"PR2 ({len(tree.links)} links, {len(PR2_WHOLE.components)} components, {len(PR2_WHOLE.body)} body parts), {args.iterations} renders each, server time:")
    print(f"{'route':22} {'median ms':>10} {'min':>8} {'max':>8}")
    for label, med, lo, hi in rows:
        print(f"{label:22} {med:10.1f} {lo:8.1f} {hi:8.1f}")
    print(f"page / JSON median ratio: {rows[0][1] / rows[1][1]:.2f}; page size {size / 1024:.0f} KiB; "
          f"target <= 300 ms: {'met' if rows[0][1] <= 300 else 'MISSED'}")


if __name__ == "__main__":
    main()
