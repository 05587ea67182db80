"""llama.cpp settings measured on a fixed workload: wall time, and whether every score stays bit-identical.

Usage: python -m benchmarks.llama_settings_bench [--rounds 3] [--leaves 24] [--test-model] [SETTING ...]

The workload is what a populate starts with: PR2's identification questions (the first `--leaves`
leaves), scored eight at a time as pipeline.abstraction.stages.asking does, then the same leaves' sensor-check
questions (a second system text: a prefix switch). Each setting runs in a fresh process (model
load not timed), the settings alternate round by round so that load from other processes hits
them alike, and the script prints per setting the median seconds, the ratio to the first setting,
and whether its scores are bit-identical to the first setting's (a setting that changes any
score would change answers, whatever its speed). SETTING names come from SETTINGS (default: all).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

# name -> (LlamaBackend keyword arguments, environment)
SETTINGS: dict[str, tuple[dict, dict]] = {
    "default": ({}, {}),
    "threads=1": ({"n_threads": 1}, {}),
    "threads=3": ({"n_threads": 3}, {}),
    "threads=4": ({"n_threads": 4}, {}),
    "omp-passive": ({}, {"OMP_WAIT_POLICY": "PASSIVE"}),
    "omp-active": ({}, {"OMP_WAIT_POLICY": "ACTIVE"}),
    "spin=300000": ({}, {"GOMP_SPINCOUNT": "300000"}),  # libgomp's own default where OMP_WAIT_POLICY is unset
    "spin=30000": ({}, {"GOMP_SPINCOUNT": "30000"}),
    "spin=10000": ({}, {"GOMP_SPINCOUNT": "10000"}),
    "spin=3000": ({}, {"GOMP_SPINCOUNT": "3000"}),
    "threads=1,omp-passive": ({"n_threads": 1}, {"OMP_WAIT_POLICY": "PASSIVE"}),
    "threads=3,omp-passive": ({"n_threads": 3}, {"OMP_WAIT_POLICY": "PASSIVE"}),
    "flash-attn": ({"flash_attn": True}, {}),
    "flash-attn,kv=q8_0": ({"flash_attn": True, "kv_type": "q8_0"}, {}),
    "n_batch=256": ({"n_batch": 256}, {}),
    "n_batch=1024": ({"n_batch": 1024}, {}),
}


def workload(leaves: int):
    """The questions, in the order the pipeline asks them (sorted by system text within a stage)."""
    from urdfkb.pipeline.reading.ingest import load_urdf
    from urdfkb.pipeline.knowledge.ontology import vocabulary
    from urdfkb.pipeline.abstraction.prompts import kind_choice, sensor_check
    from benchmarks.populate_bench import SHARED

    tree, vocab = load_urdf(SHARED / "urdf" / "pr2.urdf"), vocabulary()
    kinds = vocab.subclasses(vocab.component)
    chosen = tree.leaves()[:leaves]
    stages = [[kind_choice(vocab, kinds, leaf, tree.chain_to_root(leaf)[1:], tree.edge_to(leaf).joint_type).question
               for leaf in chosen],
              [sensor_check(leaf, leaf, tree.chain_to_root(leaf)[1:]) for leaf in chosen]]
    return [sorted(stage, key=lambda q: q.system) for stage in stages]


def worker(setting: str, leaves: int, test_model: bool) -> None:
    kwargs, _ = SETTINGS[setting]
    from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, TEST_MODEL, ensure_model
    from urdfkb.pipeline.llm.llama import LlamaBackend

    stages = workload(leaves)
    backend = LlamaBackend(ensure_model(TEST_MODEL if test_model else DEFAULT_MODEL), prefix_cache=False, **kwargs)
    try:
        start, scores = time.perf_counter(), []
        for questions in stages:
            for i in range(0, len(questions), 8):
                scores += backend.score(questions[i:i + 8])
        seconds = time.perf_counter() - start
    finally:
        backend.close()
    print(json.dumps({"seconds": seconds, "tokens": backend.stats.prompt_tokens, "scores": scores}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("settings", nargs="*", default=list(SETTINGS), help="names from SETTINGS; the first is the reference")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--leaves", type=int, default=24)
    parser.add_argument("--test-model", action="store_true", help="the small SmolLM2 model instead of the default")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.worker, args.leaves, args.test_model)
    unknown = [s for s in args.settings if s not in SETTINGS]
    if unknown:
        sys.exit(f"unknown setting(s) {unknown}; known: {', '.join(SETTINGS)}")
    runs: dict[str, list[dict]] = {s: [] for s in args.settings}
    loads = []
    for rnd in range(1, args.rounds + 1):
        for setting in args.settings:
            env = {**os.environ, **SETTINGS[setting][1]}
            cmd = [sys.executable, "-m", "benchmarks.llama_settings_bench", "--worker", setting, "--leaves", str(args.leaves)]
            cmd += ["--test-model"] if args.test_model else []
            loads.append(os.getloadavg()[0])
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
            if proc.returncode != 0:
                sys.exit(f"{setting} failed:\n{proc.stderr[-2000:]}")
            runs[setting].append(json.loads(proc.stdout.splitlines()[-1]))
            print(f"round {rnd} {setting:>24}: {runs[setting][-1]['seconds']:6.1f} s  (load average {loads[-1]:.1f})",
                  flush=True)
    reference = args.settings[0]
    ref_median = statistics.median(r["seconds"] for r in runs[reference])
    ref_scores = runs[reference][0]["scores"]
    print(f"load average during the runs: median {statistics.median(loads):.1f}, max {max(loads):.1f}")
    print(f"{'setting':>24} {'median s':>9} {'ratio':>6} {'tokens':>7}  scores")
    for setting, rs in runs.items():
        median = statistics.median(r["seconds"] for r in rs)
        same = all(r["scores"] == ref_scores for r in rs)
        drift = max(abs(a - b) for r in rs for ra, rb in zip(r["scores"], ref_scores) for a, b in zip(ra, rb))
        verdict = "bit-identical" if same else f"CHANGED (max |d log p| {drift:.3g})"
        print(f"{setting:>24} {median:9.1f} {median / ref_median:6.2f} {rs[0]['tokens']:7,}  {verdict}")


if __name__ == "__main__":
    main()
