"""Questions in words against the question set (tests/data/questions.yaml): accuracy, refusals, latency.

Builds a temporary store with the set's robots (tests/ask_robots.py: PR2 with its whole body, the TurtleBot3
Waffle Pi), loads the model once, reads each robot's menu into it with one untimed question (as a running
server has it after its first question), then asks every question, one robot's after the other's (as in a dialogue with one robot), and prints: accuracy of the in-scope
questions (query and every value right), the out-of-scope refusal rate, and the latency per question (p50,
p95) with the model loaded, and the tokens the model evaluates per question (the work behind the
latency, the same on a busy machine); then the same per fold and the accuracy per query.

The set is split into two folds by phrasing, not per question: within each expected query (refusals
included), the distinct phrasings in the order they are written alternate between `design` (the half to
tune on) and `check` (the half kept to measure); one phrasing asked of both robots stays in one fold.
Usage:
    python -m benchmarks.ask [--model GGUF | --test] [--fold design|check] [--threshold P] [--limit N] [--explain] [--save JSON]
--test runs the small SmolLM2 model.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import yaml

from tests.ask_robots import store_ask_robots
from tests.shared_assets import SHARED
from urdfkb.kb_server.ask import Asker, direct
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, TEST_MODEL, ensure_model
from urdfkb.pipeline.llm.llama import LlamaBackend
from urdfkb.settings import ASK_THRESHOLD

QUESTIONS = Path(__file__).resolve().parents[1] / "tests" / "data" / "questions.yaml"
FOLDS = ("design", "check")


def with_folds(questions: list[dict]) -> list[dict]:
    """Each question with its `fold`: its phrasing's rank among its query's phrasings, even or odd."""
    phrasings: dict[str | None, dict[str, int]] = {}
    for q in questions:
        ranks = phrasings.setdefault(q["query"], {})
        rank = ranks.setdefault(" ".join(q["q"].lower().split()), len(ranks))
        q["fold"] = FOLDS[rank % 2]
    return questions


def summary(label: str, results: list[dict]) -> list[str]:
    """Accuracy, refusals and latency of some results, in lines."""
    inside = [r for r in results if r["query"] is not None]
    outside = [r for r in results if r["query"] is None]
    right, refused = sum(r["ok"] for r in inside), sum(r["ok"] for r in outside)
    seconds = sorted(r["seconds"] for r in results)
    tokens = sorted(r["tokens"] for r in results)
    return [f"{label}: {len(results)} questions ({len(inside)} in scope, {len(outside)} out of scope)",
            f"  accuracy (query and every value right): {right}/{len(inside)} = {right / max(len(inside), 1):.1%}",
            f"  out of scope refused: {refused}/{len(outside)} = {refused / max(len(outside), 1):.1%}",
            f"  latency per question: p50 {statistics.median(seconds):.3f} s, "
            f"p95 {seconds[min(len(seconds) - 1, int(0.95 * len(seconds)))]:.3f} s, max {seconds[-1]:.3f} s",
            f"  tokens evaluated per question (the model's work, whatever the machine's load): "
            f"p50 {statistics.median(tokens):.0f}, max {tokens[-1]}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", metavar="GGUF", help="a GGUF file (default: the default model)")
    parser.add_argument("--test", action="store_true", help="the small SmolLM2-135M test model")
    parser.add_argument("--fold", choices=FOLDS, help="ask one fold's questions only")
    parser.add_argument("--threshold", type=float, default=ASK_THRESHOLD, metavar="P",
                        help=f"the probability the chosen query must hold (default {ASK_THRESHOLD}); 0 refuses only `none`")
    parser.add_argument("--limit", type=int, metavar="N", help="ask at most N questions")
    parser.add_argument("--explain", action="store_true", help="print every wrong answer")
    parser.add_argument("--save", metavar="JSON", help="write each question with its reply, latency and tokens to this file (JSON lines, as asked)")
    args = parser.parse_args()
    questions = [q for q in with_folds(yaml.safe_load(QUESTIONS.read_text()))
                 if args.fold in (None, q["fold"])][:args.limit]
    model = args.model or ensure_model(TEST_MODEL if args.test else DEFAULT_MODEL, progress=False)
    results = []
    saved = open(args.save, "w") if args.save else None  # noqa: SIM115  (written as the questions are asked)
    with tempfile.TemporaryDirectory() as folder:
        store = Store(Path(folder) / "kb.sqlite3", workers=0)
        store_ask_robots(store, load_urdf(SHARED / "urdf" / "pr2.urdf"))
        started = time.perf_counter()
        backend = LlamaBackend(model)
        print(f"model {Path(model).name} loaded in {time.perf_counter() - started:.1f} s")
        asker = Asker(direct(backend), args.threshold)
        try:
            for robot in sorted({q["robot"] for q in questions}):
                started = time.perf_counter()
                asker.ask(store, robot, "What sensors do you have?")
                print(f"{robot}: menu read in {time.perf_counter() - started:.1f} s "
                      f"({len(backend.prefix_tokens(asker.menu(store, robot).system))} prompt tokens)")
            for q in sorted(questions, key=lambda q: q["robot"]):  # one robot's dialogue, then the other's
                tokens = backend.stats.prompt_tokens
                started = time.perf_counter()
                reply = asker.ask(store, q["robot"], q["q"])
                seconds = time.perf_counter() - started
                tokens = backend.stats.prompt_tokens - tokens
                if q["query"] is None:
                    ok = reply["refused"]
                else:
                    ok = reply["query"] == q["query"] and reply["params"] == q.get("params", {})
                results.append(q | {"ok": ok, "seconds": seconds, "tokens": tokens, "reply": reply})
                if saved:
                    saved.write(json.dumps(results[-1]) + "\n")
                    saved.flush()
        finally:
            backend.close()
            store.close()
            if saved:
                saved.close()
    if args.explain:
        for r in results:
            if not r["ok"]:
                print(f"  [{r['fold']}] {r['robot']}: {r['q']!r}: expected {r['query']} {r.get('params', {})}, got "
                      f"{r['reply']['query']} {r['reply']['params']} ({r['reply']['confidence']:.2f})")
    lines = summary("all", results)
    for fold in FOLDS:
        if part := [r for r in results if r["fold"] == fold]:
            lines += summary(fold, part)
    print("\n".join(lines))
    print("accuracy per query (design, check):")
    for query in sorted({r["query"] for r in results}, key=str):
        counts = []
        for fold in FOLDS:
            part = [r for r in results if r["query"] == query and r["fold"] == fold]
            counts.append(f"{sum(r['ok'] for r in part)}/{len(part)}")
        print(f"  {query or 'out of scope (refused)'}: {', '.join(counts)}")


if __name__ == "__main__":
    main()
