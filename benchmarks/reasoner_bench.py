"""Median cost of classifying tools with HermiT: python -m benchmarks.reasoner_bench [-n RUNS].

Prints the JVM's fixed cost (a one-class ontology), the core alone, and the tools of the invented
tests/data/tool_rack.urdf (a vise, a three-prong gripper, a hand) repeated 1, 2 and 4 times in one
world, as one end-effector pass would assert them; with the ratio to the core alone.
"""
import argparse
import statistics
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import owlready2

from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.ontology import load_core
from urdfkb.pipeline.knowledge.reasoning import classify
from urdfkb.pipeline.abstraction.structure import tool_structure

REPO = Path(__file__).resolve().parents[1]
RACK = REPO / "tests" / "data" / "tool_rack.urdf"
TOOLS = (["vise_jaw_port", "vise_jaw_starboard", "vise_grip_point"],
         ["trident_motor", "trident_prong0_tip", "trident_prong1_tip", "trident_prong2_tip"],
         ["mitt_drive", "mitt_digit0_end", "mitt_digit3_end", "mitt_opposer_end"])


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def trivial() -> None:
    world = owlready2.World()
    onto = world.get_ontology("urn:bench#")
    with onto:
        owlready2.types.new_class("A", (owlready2.Thing,))
    owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)


def core_only() -> None:
    world = owlready2.World()
    load_core(world)
    owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("-n", "--runs", type=int, default=3, help="runs per case (default 3)")
    args = parser.parse_args()
    tree = load_urdf(RACK)
    structures = [tool_structure(tree, leaves) for leaves in TOOLS]
    cases: list[tuple[str, Callable[[], object]]] = [("JVM + HermiT, one class", trivial), ("core ontology alone", core_only)]
    cases += [(f"core + {3 * k} tools", partial(classify, structures * k)) for k in (1, 2, 4)]
    print(f"median of {args.runs} runs (wall clock, includes the JVM start)\n")
    print(f"| {'case':<26} | {'median s':>8} | {'x core':>6} |")
    print(f"|{'-' * 28}|{'-' * 9}:|{'-' * 7}:|")
    base = None
    for name, fn in cases:
        median = statistics.median(timed(fn) for _ in range(args.runs))
        base = median if name.startswith("core ontology") else base
        ratio = f"{median / base:.2f}" if base else "-"
        print(f"| {name:<26} | {median:>8.2f} | {ratio:>6} |")


if __name__ == "__main__":
    main()
