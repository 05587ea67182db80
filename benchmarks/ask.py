"""Questions in words against the question set (tests/data/questions.yaml): accuracy, refusals, latency.

Builds a temporary store with the set's robots (tests/ask_robots.py: PR2 with its whole body, the TurtleBot3
Waffle Pi), loads the model once, reads each robot's menu into it with one untimed question (as a running
server has it after its first question), then asks every question and prints: accuracy of the in-scope
questions (query and every value right), the out-of-scope refusal rate, and the latency per question (p50,
p95) with the model loaded. Usage:
    python -m benchmarks.ask [--model GGUF | --test] [--limit N] [--every K] [--explain]
--test runs the small SmolLM2 model; --every K asks every K-th question only (a subset for design work).
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import yaml

from tests.ask_robots import store_ask_robots
from tests.shared_assets import SHARED
from urdfkb.kb_server.ask import Asker, direct
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.ingest import load_urdf
from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, TEST_MODEL, ensure_model
from urdfkb.pipeline.llm.llama import LlamaBackend

QUESTIONS = Path(__file__).resolve().parents[1] / "tests" / "data" / "questions.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", metavar="GGUF", help="a GGUF file (default: the default model)")
    parser.add_argument("--test", action="store_true", help="the small SmolLM2-135M test model")
    parser.add_argument("--every", type=int, default=1, metavar="K", help="ask every K-th question only")
    parser.add_argument("--limit", type=int, metavar="N", help="ask at most N questions")
    parser.add_argument("--explain", action="store_true", help="print every wrong answer")
    args = parser.parse_args()
    questions = yaml.safe_load(QUESTIONS.read_text())[::args.every][:args.limit]
    model = args.model or ensure_model(TEST_MODEL if args.test else DEFAULT_MODEL, progress=False)
    with tempfile.TemporaryDirectory() as folder:
        store = Store(Path(folder) / "kb.sqlite3", workers=0)
        store_ask_robots(store, load_urdf(SHARED / "urdf" / "pr2.urdf"))
        started = time.perf_counter()
        backend = LlamaBackend(model)
        print(f"model {Path(model).name} loaded in {time.perf_counter() - started:.1f} s")
        asker = Asker(direct(backend))
        try:
            for robot in sorted({q["robot"] for q in questions}):
                started = time.perf_counter()
                asker.ask(store, robot, "What sensors do you have?")
                print(f"{robot}: menu read in {time.perf_counter() - started:.1f} s "
                      f"({len(backend.prefix_tokens(asker.menu(store, robot).system))} prompt tokens)")
            right, refused, seconds, wrong = 0, 0, [], []
            for q in questions:
                started = time.perf_counter()
                reply = asker.ask(store, q["robot"], q["q"])
                seconds.append(time.perf_counter() - started)
                if q["query"] is None:
                    refused += reply["refused"]
                    ok = reply["refused"]
                else:
                    ok = reply["query"] == q["query"] and reply["params"] == q.get("params", {})
                    right += ok
                if not ok:
                    wrong.append(f"  {q['robot']}: {q['q']!r}: expected {q['query']} {q.get('params', {})}, got "
                                 f"{reply['query']} {reply['params']} ({reply['confidence']:.2f})")
        finally:
            backend.close()
            store.close()
    in_scope = sum(q["query"] is not None for q in questions)
    out = len(questions) - in_scope
    if args.explain:
        print("\n".join(wrong))
    print(f"questions: {len(questions)} ({in_scope} in scope, {out} out of scope)")
    print(f"accuracy (query and every value right): {right}/{in_scope} = {right / max(in_scope, 1):.1%}")
    print(f"out of scope refused: {refused}/{out} = {refused / max(out, 1):.1%}")
    seconds.sort()
    print(f"latency per question: p50 {statistics.median(seconds):.3f} s, "
          f"p95 {seconds[min(len(seconds) - 1, int(0.95 * len(seconds)))]:.3f} s, max {seconds[-1]:.3f} s")


if __name__ == "__main__":
    main()
