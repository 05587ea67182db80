"""The abstraction passes, sensors, end-effectors, then the body, each a declared list of steps (PASSES),
and the Abstractor that runs them over one robot at a time.

End-effectors skip pre- and post-classification: after verification their extent and mount are settled
from structure and their kind inferred by a reasoner from the ontology's definitions (pipeline.abstraction.steps.tools);
the model is asked the kind only where the structure settles none. After a pass, the links of its
components are removed from the tree (each device condensed onto its mount), so the next pass sees a
smaller tree and never claims a link twice (but for a sensor the screen will hold, whose links stay). The body pass
then sees the whole robot again and groups the movable joints no device owns into body parts. Every schema fact comes from the Vocabulary
(pipeline.knowledge.ontology). The steps are functions in pipeline.abstraction.steps, each declaring the fields of the findings
record it reads and makes; pipeline.abstraction.passes checks the declarations and runs the steps.
"""
from __future__ import annotations

from typing import Callable

from urdfkb.pipeline.knowledge import reasoning
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.ontology import Vocabulary
from urdfkb.pipeline.knowledge.screen import unsure
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.passes import Pass, PassManager, check_order
from urdfkb.pipeline.abstraction.stages.asking import Progress
from urdfkb.pipeline.abstraction.steps import body, classify, devices, identify, tools
from urdfkb.pipeline.abstraction.steps.assembly import assembly, tool_assembly
from urdfkb.pipeline.abstraction.steps.context import Context, Log, Tally, write_trace
from urdfkb.pipeline.abstraction.steps.findings import LASTING, Findings
from urdfkb.pipeline.abstraction.steps.shape import shape
from urdfkb.pipeline.reading.tree import KinematicTree

BODY = "body"  # the pass that finds no component kind: body parts

SENSOR_PASS = Pass(SENSOR, (
    shape,
    identify.identification,
    identify.mimic_veto,
    identify.sensor_check,
    devices.rigid_attachment,
    classify.pre_classification,
    classify.built_in_frames,
    devices.group_merging,
    devices.verification,
    classify.post_classification,
    classify.numbered_units,
    classify.subpart_typing,
    assembly,
))

END_EFFECTOR_PASS = Pass(END_EFFECTOR, (
    identify.identification,
    devices.attachment,
    devices.tool_merging,
    devices.verification,
    tools.tool_extent,
    tools.reasoner,
    tools.tool_classification,
    classify.tool_subpart_typing,
    tool_assembly,
))

BODY_PASS = Pass(BODY, (
    body.device_joints,
    body.candidates,
    body.body_classification,
    body.body_assembly,
    body.jointless_base,
    body.sides,
    body.location,
    body.placement,
))

# Run in this order; a device pass is named by the core:componentKind of the components it finds, and
# removes them from the tree the next device pass sees, but those the screen will hold (screen.unsure: a sensor
# under the floor is no device, and what it stood for may be a tool's, as a gripper's fixed finger).
PASSES = (SENSOR_PASS, END_EFFECTOR_PASS, BODY_PASS)
GIVEN = ("components",)  # what a robot's findings start with: no components yet
check_order(PASSES, given=GIVEN, lasting=LASTING)


class Abstractor:
    """Runs the passes over one robot at a time, each robot with a fresh findings record and tally."""

    def __init__(self, oracle: Oracle, vocab: Vocabulary, progress: Progress | None = None, log: Log | None = None,
                 record: Callable[[dict], None] | None = None, reasoner: reasoning.Reasoner = reasoning.classify_together,
                 placer: reasoning.Placer = reasoning.placements, passes: tuple[Pass, ...] = PASSES):
        """`record` receives each step's timing record (default: the oracle's trace); `reasoner` classifies
        tools and body candidates from their facts, `placer` says which classes a body part rules out for what
        sits on it (HermiT both; tests inject stand-ins); `passes` are run in order."""
        if missing := [k for k in vocab.kinds if k not in {p.name for p in passes}]:
            raise OntologyError(f"no pass declared for component kind(s) {missing} (pipeline.abstraction.abstractor.PASSES)")
        self.oracle, self.vocab, self.progress, self.log = oracle, vocab, progress, log or (lambda _msg: None)
        self.reasoner, self.placer, self.passes = reasoner, placer, passes
        self.record = record or (lambda timing: write_trace(oracle, timing))
        self.tally = Tally()  # the counts of the last robot run

    def context(self, robot: KinematicTree, tree: KinematicTree | None = None, kind: str | None = None) -> Context:
        """A pass's context: `tree` (default: the whole robot) is what it sees, `kind` the component kind it finds."""
        return Context(robot, robot if tree is None else tree, self.vocab.kinds.get(kind) if kind else None, self.oracle, self.vocab,
                       self.progress, self.log, self.reasoner, self.placer, self.tally)

    def run(self, robot: KinematicTree) -> Findings:
        """What the passes find about `robot`: its components and body parts among the findings."""
        self.tally = Tally()
        findings, tree = Findings(), robot
        manager = PassManager(self.record, self._counters)
        for declared in self.passes:
            findings = findings.next_pass()
            manager.run(declared, self.context(robot, tree, declared.name), findings)
            tree = tree.without({link for c in findings.found if not unsure(robot, c) for link in c.links})
        return findings

    def _counters(self) -> dict[str, float]:
        """Running totals of the work a step does, for its timing record (pipeline.timings)."""
        stats = self.oracle.stats
        return {"model_seconds": self.oracle.seconds, "tokens": stats.prompt_tokens,
                "restored_tokens": stats.restored_tokens, "decodes": stats.calls,
                "reasoner_seconds": self.tally.reasoner_seconds}
