"""Exact voting against sampled voting (K=5) on PR2, side by side in one run.

Each mode runs the whole pipeline cold (model load included, result cache off) and is scored
against the truth file; the table gives wall time, LLM calls, prompt tokens and accuracy, and
the ratios sample / exact. Usage: python -m benchmarks.vote_bench [--robot pr2] [--votes 5]
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

from urdfkb.pipeline.runner import Settings
from urdfkb.pipeline.scoring.truth_run import run_truth_robot

SHARED = Path(os.environ.get("URDFKB_SHARED", Path(__file__).resolve().parents[2] / "shared"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robot", default="pr2")
    parser.add_argument("--votes", type=int, default=5)
    args = parser.parse_args()
    truth = SHARED / "eval" / "truth" / f"{args.robot}.yaml"
    modes = {"exact": Settings(vote="exact", use_cache=False),
             f"sample x{args.votes}": Settings(vote="sample", votes=args.votes, use_cache=False)}
    rows = {}
    for label, settings in modes.items():
        result = run_truth_robot(truth, settings)
        prov, scores = result.abstraction.provenance, result.scores["all"]
        rows[label] = {"wall s": result.seconds, "llm calls": int(prov["llm_calls"]),
                       "prompt tokens": int(prov["prompt_tokens"]), "typed F1": scores["typed_f1"],
                       "root acc": scores["root_accuracy"], "subpart acc": scores["subpart_accuracy"]}
        print(f"{label}: done in {result.seconds:.1f} s", flush=True)
    columns = list(next(iter(rows.values())))
    exact, sample = rows.values()
    print(f"\n{args.robot}: exact vs sampled voting (cold model load, no cache)")
    print(f"{'mode':12}" + "".join(f"{c:>15}" for c in columns))
    for label, row in rows.items():
        print(f"{label:12}" + "".join(f"{row[c]:>15.3f}" if isinstance(row[c], float) else f"{row[c]:>15}" for c in columns))
    ratio = "".join(f"{(sample[c] / exact[c] if exact[c] else float('nan')):>15.2f}" for c in columns)
    print(f"{'sample/exact':12}" + ratio)


if __name__ == "__main__":
    main()
