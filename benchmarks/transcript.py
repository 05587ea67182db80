"""Every question the pipeline asks on the truth robots, and the triples it writes, with a model stand-in.

A deterministic backend answers from a hash of each question's text, so two revisions of the
pipeline can be compared without a model: a refactor that changes no prompt, option, answer or
triple gives identical transcripts. Per robot it writes ROBOT.questions.jsonl (backend call, system
prompt, user prompt, options, the probabilities given) and ROBOT.nt (the robot's own graph as sorted N-Triples, blank
nodes canonical, without the populate's timestamp and wall time).

Usage: python -m benchmarks.transcript OUT_DIR [TRUTH_DIR] [--salt S] [--traces DIR]; then `diff -r OUT_A OUT_B`.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import tempfile
from pathlib import Path

import owlready2
import rdflib
from rdflib.compare import to_canonical_graph

from urdfkb.pipeline.scoring.truth import load_truth
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.runner import Settings, run

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("URDFKB_SHARED", REPO.parent / "shared"))
VARYING = ("#generatedAt>", "#wallTimeSeconds>")  # predicates whose values differ from run to run


def hashed(question: Question, salt: str = "") -> dict[str, float]:
    """Probabilities drawn from a hash of the whole question (and `salt`): the same text always gets the same answer."""
    text = json.dumps([salt, question.system, question.user, question.options])
    weights = [int.from_bytes(hashlib.sha256((text + o).encode()).digest()[:4], "big") + 1 for o in question.options]
    return {o: w / sum(weights) for o, w in zip(question.options, weights)}


def transcribe(truth_path: Path, out: Path, traces: Path | None = None, salt: str = "") -> int:
    """Write one truth robot's transcript (and its oracle trace into `traces`); the number of questions asked."""
    truth = load_truth(truth_path)
    tree = load_urdf(truth_path.resolve().parents[2] / truth.urdf)
    asked: list[dict] = []
    batches: list[int] = []

    def rule(question: Question) -> dict[str, float]:
        shares = hashed(question, salt)
        asked.append({"batch": len(batches), "key": question.key, "system": question.system, "user": question.user,
                      "options": list(question.options), "shares": shares})
        return shares

    class Batching(ScriptedBackend):  # numbers each call, since a real model's answers depend on the batch
        def score(self, questions):
            batches.append(len(questions))
            return super().score(questions)

    trace = (traces / f"{truth.robot}.trace.jsonl").open("w") if traces else None
    try:
        abstraction = run(tree, Settings(use_cache=False), backend=Batching(rule, name="hashed"), trace=trace)
    finally:
        if trace:
            trace.close()
    onto = build_robot(owlready2.World(), tree, truth.robot, abstraction)
    with tempfile.TemporaryFile() as f:
        onto.save(f, format="ntriples")
        f.seek(0)
        graph = to_canonical_graph(rdflib.Graph().parse(f, format="nt"))  # blank nodes named by content
    lines = sorted(line for line in graph.serialize(format="nt").splitlines()
                   if line.strip() and not any(p in line for p in VARYING))
    (out / f"{truth.robot}.questions.jsonl").write_text("".join(json.dumps(q) + "\n" for q in asked))
    (out / f"{truth.robot}.nt").write_text("\n".join(lines) + "\n")
    return len(asked)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("truth", nargs="?", type=Path, default=SHARED / "eval" / "truth")
    parser.add_argument("--salt", default="", help="another deterministic model: other answers, other paths taken")
    parser.add_argument("--traces", type=Path, help="also keep each robot's JSON-lines trace (timings vary) here")
    args = parser.parse_args()
    for folder in (args.out, args.traces):
        if folder:
            folder.mkdir(parents=True, exist_ok=True)
    for path in sorted(args.truth.glob("*.yaml")):
        print(f"{path.stem}: {transcribe(path, args.out, args.traces, args.salt)} questions", flush=True)


if __name__ == "__main__":
    main()
