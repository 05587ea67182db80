"""Score the pipeline over the parts library: each part on each of its hosts, typed component F1 per part and overall.

Usage: python -m benchmarks.parts [--parts NAME ...] [--hosts HOST ...] [--limit N] [--out DIR] [--json FILE]
                                  [--structure-only] [--model GGUF | --llm-url URL [--llm-model NAME]] [--no-cache]

Runs the default model unless told otherwise (minutes a robot: the whole library is a long run). --out keeps the generated URDFs and truth files, so `urdfkb eval DIR/eval/truth` scores the
same robots; --json keeps every robot's scores (`urdfkb eval --json`'s form), so runs over different hosts can
be put together. Before the last line come the typed F1 per host and the review queue's line (as `urdfkb
eval` prints it: the share of wrong components it holds, the share of all it takes). The last line reads `parts P, makers M, hosts per part >= H, typed F1 X.XX`.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from statistics import fmean

from benchmarks.parts.hosts import HOSTS
from benchmarks.parts.library import load_all
from benchmarks.parts.robots import robots, write


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.parts", description=__doc__.splitlines()[0])
    p.add_argument("--parts", nargs="+", metavar="NAME", help="only these parts (file stems of benchmarks/parts/data)")
    p.add_argument("--hosts", nargs="+", choices=HOSTS, help="only these hosts")
    p.add_argument("--limit", type=int, metavar="N", help="only the first N robots")
    p.add_argument("--out", metavar="DIR", help="write the robots' URDFs and truth here (DIR/urdf, DIR/eval/truth)")
    p.add_argument("--json", metavar="FILE", help="write each robot's part, host and scores to FILE")
    p.add_argument("--structure-only", action="store_true", help="no model: links and joints only (checks the run, scores nothing)")
    p.add_argument("--model", metavar="GGUF", help="a GGUF model file instead of the default model")
    p.add_argument("--llm-url", metavar="URL", help="an OpenAI-compatible server instead of the embedded model")
    p.add_argument("--llm-model", metavar="NAME", help="the model name to request from --llm-url")
    p.add_argument("--no-cache", action="store_true", help="ignore and do not write the result cache")
    args = p.parse_args(argv)

    from urdfkb.pipeline.runner import Settings
    from urdfkb.pipeline.scoring.evaluation import mean_scores
    from urdfkb.pipeline.scoring.evaluation_report import review_queue
    from urdfkb.pipeline.scoring.truth_run import run_truth_robot

    parts = load_all()
    if args.parts:
        unknown = set(args.parts) - {part.key for part in parts}
        if unknown:
            p.error(f"no part {', '.join(sorted(unknown))} (parts: {', '.join(part.key for part in parts)})")
        parts = [part for part in parts if part.key in args.parts]
    settings = Settings(structure_only=args.structure_only, model=args.model, llm_url=args.llm_url,
                        llm_model=args.llm_model, use_cache=not args.no_cache)
    try:
        settings.check()
    except ValueError as e:
        p.error(str(e))
    chosen = list(robots(parts, args.hosts))[:args.limit]
    folder = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="urdfkb-parts-"))
    per_part: dict[str, list[float]] = {}
    per_host: dict[str, list[float]] = {}
    runs: dict[str, dict] = {}
    for part, host, robot in chosen:
        truth = write(robot, part, folder)
        run = run_truth_robot(truth, settings)
        f1 = run.scores["all"]["typed_f1"]
        per_part.setdefault(part.key, []).append(f1)
        per_host.setdefault(host, []).append(f1)
        runs[robot.name] = {"part": part.key, "host": host, "scores": run.scores}
        print(f"{robot.name:45s} typed F1 {f1:.3f}  body {_cell(run.scores['body']['typed_f1'])}  {run.seconds:.0f} s",
              file=sys.stderr, flush=True)
    print("| part | maker | hosts | typed F1 |\n|---|---|---|---|")
    by_key = {part.key: part for part in parts}
    for key, scores in per_part.items():
        print(f"| {key} | {by_key[key].maker} | {len(scores)} | {fmean(scores):.3f} |")
    scored = [by_key[k] for k in per_part]
    overall = fmean(s for scores in per_part.values() for s in scores) if per_part else 0.0
    least = min((len(scores) for scores in per_part.values()), default=0)
    for host, scores in per_host.items():
        print(f"{host}: {len(scores)} robots, typed F1 {fmean(scores):.3f}")
    if runs:
        print(review_queue(mean_scores({name: r["scores"] for name, r in runs.items()})))
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))
    if args.out:
        print(f"robots written to {folder} (score them again with `urdfkb eval {folder / 'eval' / 'truth'}`)")
    print(f"parts {len(scored)}, makers {len({part.maker for part in scored})}, hosts per part >= {least}, typed F1 {overall:.2f}")
    return 0


def _cell(value) -> str:
    return "-" if value is None else f"{value:.3f}"


if __name__ == "__main__":
    raise SystemExit(main())
