"""The accuracy table of docs/accuracy.md from an `urdfkb eval --json` file: one row a robot with its fold, the mean,
each fold's.

Usage: python -m benchmarks.accuracy_table EVAL.json [BEFORE.json]

With BEFORE.json, a last column gives each robot's typed component F1 in that run, and the means' rows
say it too, so a change's table shows what moved.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import yaml

FOLDS = Path(__file__).with_name("folds.yaml")
COLUMNS = [("typed component F1", "all", "typed_f1"), ("component F1", "all", "component_f1"),
           ("leaf F1", "all", "leaf_f1"), ("root", "all", "root_accuracy"), ("subpart", "all", "subpart_accuracy"),
           ("body typed part F1", "body", "typed_f1"), ("side", "body", "side_accuracy"),
           ("body root", "body", "root_accuracy"), ("joint", "body", "joint_accuracy")]


def cell(value) -> str:
    return "-" if value is None else f"{value:.3f}"


def row(label: str, scores: dict, extra: list[str]) -> str:
    return "| " + " | ".join([label, *(cell(scores[scope][m]) for _, scope, m in COLUMNS), *extra]) + " |"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.accuracy_table", description=__doc__.splitlines()[0])
    p.add_argument("eval_json", metavar="EVAL.json", help="a run written by `urdfkb eval --json`")
    p.add_argument("before_json", metavar="BEFORE.json", nargs="?", help="an earlier run, for a typed F1 before column")
    args = p.parse_args(argv)
    run = json.loads(Path(args.eval_json).read_text())
    before = json.loads(Path(args.before_json).read_text()) if args.before_json else None
    fold_of = {r: f for f, robots in yaml.safe_load(FOLDS.read_text()).items() for r in robots}
    head = ["robot", *(c for c, _, _ in COLUMNS), "LLM decodes", "prompt tokens", "wall time"]
    head += ["typed F1 before"] if before else []
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for robot, scores in run["robots"].items():
        info = run["run"]
        extra = [str(info["llm calls"].get(robot, "")), f"{int(info['tokens'].get(robot, 0)):,}",
                 f"{float(info['seconds'].get(robot, 0)):.0f} s"]
        extra += [cell(before["robots"][robot]["all"]["typed_f1"])] if before else []
        print(row(f"{robot} ({fold_of.get(robot, '?')})", scores, extra))
    means = [("**mean**", run["mean"], before["mean"] if before else None)]
    means += [(f"mean {f}", m, before["folds"][f] if before else None) for f, m in run.get("folds", {}).items()]
    for label, scores, old in means:
        print(row(label, scores, ["", "", ""] + ([cell(old["all"]["typed_f1"])] if old else [])))


if __name__ == "__main__":
    main()
