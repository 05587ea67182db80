"""Whole-body metrics (spec/evaluation.md, "Whole body") on hand-built trees and graphs, through
population, and a guard on the body sections of the shared truth files."""
import json
import os
from pathlib import Path

import owlready2
import pytest
import rdflib
from rdflib import RDF, RDFS

from urdfkb.pipeline.abstraction.components import Abstraction, BodyPart
from urdfkb.pipeline.scoring.body_scoring import BODY, BODY_METRICS, end_effector_joints, scored_joints
from urdfkb.pipeline.scoring.evaluation import failed_scores, mean_scores, score
from urdfkb.pipeline.scoring.evaluation_report import format_table
from urdfkb.pipeline.knowledge.namespaces import CORE
from urdfkb.pipeline.scoring.prediction import read_body
from urdfkb.pipeline.scoring.truth import load_truth
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin

SHARED = Path(os.environ.get("URDFKB_SHARED", Path(__file__).resolve().parents[2] / "shared")).resolve()

# A wheeled, two-armed toy: a jointless chassis, two wheels, a tilting laser (ignored joint), a torso
# lift, a pan/tilt head and two 3-joint arms, each ending in a one-finger gripper.
JOINTS = [  # (joint, type, parent, child)
    ("wheel_l_joint", "continuous", "base_link", "wheel_l"),
    ("wheel_r_joint", "continuous", "base_link", "wheel_r"),
    ("bumper_joint", "fixed", "base_link", "bumper"),
    ("tilt_joint", "revolute", "base_link", "tilt_link"),
    ("laser_joint", "fixed", "tilt_link", "laser_link"),
    ("torso_joint", "prismatic", "base_link", "torso_link"),
    ("head_pan", "revolute", "torso_link", "head_pan_link"),
    ("head_tilt", "revolute", "head_pan_link", "head_tilt_link"),
    *[j for s in "lr" for j in [
        (f"{s}_shoulder", "revolute", "torso_link", f"{s}_upper"),
        (f"{s}_elbow", "revolute", f"{s}_upper", f"{s}_fore"),
        (f"{s}_wrist", "revolute", f"{s}_fore", f"{s}_wrist_link"),
        (f"{s}_finger_joint", "prismatic", f"{s}_wrist_link", f"{s}_finger"),
        (f"{s}_tcp_joint", "fixed", f"{s}_wrist_link", f"{s}_tcp"),
    ]],
]
TREE = KinematicTree("toybot", ("base_link", *(child for *_, child in JOINTS)),
                     tuple(Edge(j, t, p, c, Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))) for j, t, p, c in JOINTS))
LEAVES = set(TREE.leaves())
ARM = {s: [f"{s}_shoulder", f"{s}_elbow", f"{s}_wrist"] for s in "lr"}
TRUTH = """
robot: toybot
urdf: urdf/toybot.urdf
ignore: []
components:
  - {id: laser, kind: sensor, classes: [Lidar], roots: [tilt_link], leaves: [laser_link]}
  - {id: l_gripper, kind: end_effector, classes: [ParallelGripper], roots: [l_wrist_link, l_fore], leaves: [l_finger, l_tcp]}
  - {id: r_gripper, kind: end_effector, classes: [ParallelGripper], roots: [r_wrist_link, r_fore], leaves: [r_finger, r_tcp]}
body:
  ignore_joints: [tilt_joint]
  parts:
    - {id: base, classes: [MobileBase], roots: [], joints: [], links: [base_link]}
    - {id: wheel_l, classes: [Wheel], side: left, roots: [base_link], joints: [wheel_l_joint]}
    - {id: wheel_r, classes: [Wheel], side: right, roots: [base_link], joints: [wheel_r_joint]}
    - {id: torso, classes: [Torso, Leg], roots: [base_link], joints: [torso_joint]}
    - {id: head, classes: [PanTiltHead], roots: [torso_link], joints: [head_pan, head_tilt]}
    - {id: left_arm, classes: [Arm], side: left, roots: [torso_link], joints: [l_shoulder, l_elbow, l_wrist]}
    - {id: right_arm, classes: [Arm], side: right, roots: [torso_link], joints: [r_shoulder, r_elbow, r_wrist]}
"""
SCORED = {"wheel_l_joint", "wheel_r_joint", "torso_joint", "head_pan", "head_tilt", *ARM["l"], *ARM["r"]}

HIERARCHY = {
    "Sensor": "Component", "EndEffector": "Component", "BodyPart": "Component", "Lidar": "Sensor",
    "Gripper": "EndEffector", "ParallelGripper": "Gripper",
    **dict.fromkeys(["MobileBase", "Wheel", "Arm", "Leg", "Head", "Torso"], "BodyPart"),
    "PanTiltHead": "Head",  # a finer class, for the ancestor half credit
}


def part(cls, joints=(), links=(), root=None, side=None, parent=None):
    return {"cls": cls, "joints": list(joints), "links": list(links), "root": root, "side": side, "parent": parent}


PERFECT = {
    "base": part("MobileBase", links=["base_link"]),
    "wheel_l": part("Wheel", ["wheel_l_joint"], ["wheel_l"], "base_link", "left", parent="base"),
    "wheel_r": part("Wheel", ["wheel_r_joint"], ["wheel_r"], "base_link", "right", parent="base"),
    "torso": part("Torso", ["torso_joint"], ["torso_link"], "base_link"),
    "head": part("PanTiltHead", ["head_pan", "head_tilt"], ["head_pan_link", "head_tilt_link"], "torso_link"),
    "left_arm": part("Arm", ARM["l"], ["l_upper", "l_fore", "l_wrist_link"], "torso_link", "left"),
    "right_arm": part("Arm", ARM["r"], ["r_upper", "r_fore", "r_wrist_link"], "torso_link", "right"),
}


def graph(parts: dict, sensors: bool = True) -> rdflib.Graph:
    """A populated toybot: every link and joint with its urdfName, the robot's laser and grippers,
    and `parts` (name -> part(...)) as body parts under the robot or their parent part."""
    g = rdflib.Graph()
    for sub, sup in HIERARCHY.items():
        g.add((CORE[sub], RDFS.subClassOf, CORE[sup]))
    robot = CORE.robot
    g.add((robot, RDF.type, CORE.Robot))
    for name in TREE.links:
        g.add((CORE["link_" + name], RDF.type, CORE.Link))
        g.add((CORE["link_" + name], CORE.urdfName, rdflib.Literal(name)))
        g.add((robot, CORE.hasLink, CORE["link_" + name]))
    for edge in TREE.edges:
        g.add((CORE["joint_" + edge.joint], CORE.urdfName, rdflib.Literal(edge.joint)))
        g.add((robot, CORE.hasJoint, CORE["joint_" + edge.joint]))      # the robot is no body part
    if sensors:
        g.add((robot, CORE.hasComponent, CORE.laser))
        g.add((CORE.laser, RDF.type, CORE.Lidar))
        g.add((CORE.laser, CORE.hasLink, CORE.link_laser_link))
        for s in "lr":
            grip = CORE[f"{s}_gripper"]
            g.add((robot, CORE.hasComponent, grip))
            g.add((grip, RDF.type, CORE.ParallelGripper))
            g.add((grip, CORE.hasJoint, CORE[f"joint_{s}_finger_joint"]))
            for leaf in (f"{s}_finger", f"{s}_tcp"):
                g.add((grip, CORE.hasLink, CORE["link_" + leaf]))
    for name, p in parts.items():
        node = CORE["body_" + name]
        g.add((CORE["body_" + p["parent"]] if p["parent"] else robot, CORE.hasComponent, node))
        g.add((node, RDF.type, CORE[p["cls"]]))
        for j in p["joints"]:
            g.add((node, CORE.hasJoint, CORE["joint_" + j]))
        for link in p["links"]:
            g.add((node, CORE.hasLink, CORE["link_" + link]))
        if p["root"]:
            g.add((node, CORE.isMountedOn, CORE["link_" + p["root"]]))
        if p["side"]:
            g.add((node, CORE.side, rdflib.Literal(p["side"])))
    return g


@pytest.fixture
def truth(tmp_path):
    path = tmp_path / "toybot.yaml"
    path.write_text(TRUTH)
    return load_truth(path)


def body(truth, parts: dict) -> dict:
    return score(truth, graph(parts), LEAVES, TREE)[BODY]


def changed(**parts) -> dict:
    """PERFECT with some parts replaced (a None value drops the part)."""
    return {k: v for k, v in {**PERFECT, **parts}.items() if v is not None}


def test_truth_body_section_parses(truth):
    assert truth.body.ignore_joints == {"tilt_joint"}
    by_id = {p.id: p for p in truth.body.parts}
    assert by_id["base"].joints == frozenset() and by_id["base"].links == ("base_link",)
    assert by_id["left_arm"].side == "left" and by_id["torso"].side is None
    assert by_id["torso"].classes == {"Torso", "Leg"}


def test_scored_joints_are_movable_minus_ignored_minus_end_effector_joints(truth):
    # the nearest accepted root (l_wrist_link, not l_fore) bounds the gripper: l_wrist stays an arm joint
    assert end_effector_joints(truth, TREE) == {f"{s}_{j}_joint" for s in "lr" for j in ("finger", "tcp")}
    assert scored_joints(truth, TREE) == SCORED


def test_perfect_prediction_scores_one(truth):
    s = body(truth, PERFECT)
    assert all(s[m] == 1.0 for m in BODY_METRICS), s
    assert (s["n_predicted"], s["n_truth"], s["n_matched"], s["n_joints"]) == (7, 7, 7, 11)


def test_parts_are_read_through_other_parts_and_only_under_body_part(truth):
    parts = {p.node.rsplit("#", 1)[1]: p for p in read_body(graph(PERFECT))}
    assert set(parts) == {f"body_{name}" for name in PERFECT}          # no laser, gripper or robot
    wheel = parts["body_wheel_l"]                                      # reached robot -> base -> wheel
    assert (wheel.cls, wheel.side, wheel.root, wheel.joints, wheel.links) == (
        "Wheel", "left", "base_link", {"wheel_l_joint"}, {"wheel_l"})
    assert parts["body_base"].root is None and parts["body_base"].joints == frozenset()
    g = graph(PERFECT)
    g.remove((CORE.body_base, CORE.hasComponent, CORE.body_wheel_l))     # an orphan part is not the robot's
    assert "body_wheel_l" not in {p.node.rsplit("#", 1)[1] for p in read_body(g)}
    s = score(truth, g, LEAVES, TREE)[BODY]
    assert s["n_matched"] == 6 and s["joint_accuracy"] == pytest.approx(10 / 11)


def test_no_body_predicted_scores_zero(truth):
    s = body(truth, {})
    assert s["part_f1"] == s["typed_f1"] == 0.0
    assert s["side_accuracy"] == s["root_accuracy"] == s["joint_accuracy"] == 0.0
    assert (s["n_predicted"], s["n_truth"], s["n_matched"]) == (0, 7, 0)


def test_ignored_and_end_effector_joints_are_not_scored(truth):
    arm = part("Arm", [*ARM["l"], "l_finger_joint"], root="torso_link", side="left")   # holds the gripper's joint
    torso = part("Torso", ["torso_joint", "tilt_joint"], root="base_link")             # and the ignored laser tilt
    tilter = part("Head", ["tilt_joint"], root="base_link")                            # nothing scored left
    fingers = part("Arm", ["r_finger_joint"], root="r_wrist_link")
    s = body(truth, changed(left_arm=arm, torso=torso, tilter=tilter, fingers=fingers))
    assert s["typed_f1"] == 1.0 and s["n_predicted"] == 7                              # the last two are not counted
    assert s["joint_accuracy"] == 1.0 and s["n_joints"] == 11


def test_jointless_base_matches_by_its_first_link_and_an_accepted_class(truth):
    assert body(truth, changed(base=part("MobileBase", links=["base_link", "bumper"])))["typed_f1"] == 1.0
    for wrong in (part("Torso", links=["base_link"]),            # not an accepted class
                  part("BodyPart", links=["base_link"]),         # nor is an ancestor
                  part("MobileBase", links=["bumper"])):         # not its link
        s = body(truth, changed(base=wrong))
        # the unmatched jointless prediction is not counted: precision stays 1, recall loses the base
        assert (s["n_predicted"], s["n_matched"]) == (6, 6)
        assert (s["part_precision"], s["part_recall"]) == (1.0, pytest.approx(6 / 7))
    # a jointed prediction may hold the base too (spec: an accepted class and the link suffice) ...
    merged = part("MobileBase", ["wheel_l_joint", "wheel_r_joint"], ["base_link", "wheel_l", "wheel_r"])
    s = body(truth, changed(base=merged, wheel_l=None, wheel_r=None))
    assert (s["n_predicted"], s["n_matched"], s["part_recall"]) == (5, 5, pytest.approx(5 / 7))
    # ... but never one whose joints match a jointed truth part
    s = body(truth, changed(wheel_l=part("MobileBase", ["wheel_l_joint"], ["base_link", "wheel_l"], parent="base")))
    assert (s["n_matched"], s["typed_precision"]) == (7, pytest.approx(6 / 7))          # it matched wheel_l, typed 0


def test_side(truth):
    swapped = {**PERFECT["left_arm"], "side": "right"}
    s = body(truth, changed(left_arm=swapped, torso={**PERFECT["torso"], "side": "left"}))
    assert s["typed_f1"] == 1.0                                     # side does not affect the match
    assert s["side_accuracy"] == 0.75                               # 4 sided truth parts; torso has no side
    assert s["joint_accuracy"] == pytest.approx(8 / 11)             # the left arm's 3 joints are on the wrong side
    unsided = {**PERFECT["left_arm"], "side": None}
    assert body(truth, changed(left_arm=unsided))["side_accuracy"] == 0.75


def test_ancestor_class_gets_half_credit_and_any_accepted_class_full(truth):
    s = body(truth, changed(head={**PERFECT["head"], "cls": "Head"}, torso={**PERFECT["torso"], "cls": "Leg"}))
    assert s["part_f1"] == 1.0
    assert s["typed_f1"] == pytest.approx(6.5 / 7)
    assert s["joint_accuracy"] == pytest.approx(10 / 11)            # two head joints at 0.5
    s = body(truth, changed(head={**PERFECT["head"], "cls": "BodyPart"}))   # not strictly below BodyPart
    assert s["typed_f1"] == pytest.approx(6 / 7) and s["joint_accuracy"] == pytest.approx(9 / 11)


def test_root(truth):
    s = body(truth, changed(left_arm={**PERFECT["left_arm"], "root": "base_link"}))
    assert s["root_accuracy"] == pytest.approx(5 / 6)               # the rootless base is not scored
    assert s["typed_f1"] == 1.0


def test_joint_claimed_by_two_parts_scores_zero(truth):
    greedy_torso = part("Torso", ["torso_joint", "head_pan"], root="base_link")
    s = body(truth, changed(torso=greedy_torso))
    assert s["n_matched"] == 6                                      # the torso no longer matches...
    assert s["joint_accuracy"] == pytest.approx(10 / 11)            # ...but its own joint still scores


def test_a_robot_without_body_parts(tmp_path):
    path = tmp_path / "hand.yaml"
    path.write_text(TRUTH.split("body:")[0] + "body:\n  ignore_joints: []\n  parts: []\n")
    hand = load_truth(path)
    s = score(hand, graph({}), LEAVES, TREE)[BODY]
    assert (s["part_f1"], s["typed_f1"]) == (1.0, 1.0)
    assert s["side_accuracy"] is s["root_accuracy"] is s["joint_accuracy"] is None
    noisy = score(hand, graph({"arm": PERFECT["left_arm"]}), LEAVES, TREE)[BODY]
    assert (noisy["typed_precision"], noisy["typed_f1"]) == (0.0, 0.0)


def test_body_undefined_without_tree_or_body_section(truth, tmp_path):
    assert all(v is None for k, v in score(truth, graph(PERFECT), LEAVES)[BODY].items() if k in BODY_METRICS)
    path = tmp_path / "old.yaml"
    path.write_text(TRUTH.split("body:")[0])
    old = load_truth(path)
    assert old.body is None
    s = score(old, graph(PERFECT), LEAVES, TREE)
    assert all(s[BODY][m] is None for m in BODY_METRICS)
    assert s["all"]["typed_f1"] == 1.0                              # the components still score


def test_mean_failed_table_and_json(truth):
    per_robot = {"toybot": score(truth, graph(PERFECT), LEAVES, TREE),
                 "bare": score(truth, graph({}), LEAVES, TREE),
                 "broken": failed_scores()}
    mean = mean_scores(per_robot)
    assert mean[BODY]["typed_f1"] == pytest.approx(1 / 3)
    assert mean[BODY]["n_truth"] == 14 and mean["failed"] == 1
    table = format_table(per_robot)
    assert "sensor" in table and "TYPED_F1" in table                  # the component blocks stay
    block = next(b for b in table.split("\n\n") if b.startswith("body"))
    lines = block.splitlines()
    assert lines[0].split() == ["body", "partP", "partR", "partF1", "typedP", "typedR", "BODY_F1", "side", "root",
                                "joint"]
    assert lines[-1].split() == ["mean", *["0.333"] * 9]                  # 1, 0 (nothing predicted) and 0 (failed)
    json.dumps({"robots": per_robot, "mean": mean})


def test_eval_command_prints_and_writes_the_body(tmp_path, monkeypatch, capsys):
    """`urdfkb eval` (its pipeline run replaced by scoring a hand-built graph): the body block in the
    printed table and a "body" entry per robot and in the mean of --json."""
    from urdfkb.kb_server import cli
    from urdfkb.pipeline.scoring import truth_run

    def fake_run(path, settings, progress=None, trace=None):
        truth = load_truth(path)
        return truth_run.RobotRun(truth.robot, score(truth, graph(PERFECT), LEAVES, TREE),
                                  Abstraction(provenance={"model": "scripted", "vote": "exact"}), 0.1)
    monkeypatch.setattr(truth_run, "run_truth_robot", fake_run)
    (tmp_path / "truth").mkdir()
    (tmp_path / "truth" / "toybot.yaml").write_text(TRUTH)
    out = tmp_path / "scores.json"
    assert cli.main(["eval", str(tmp_path / "truth"), "--json", str(out), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "BODY_F1" in printed and "TYPED_F1" in printed
    data = json.loads(out.read_text())
    assert data["robots"]["toybot"][BODY]["typed_f1"] == data["mean"][BODY]["typed_f1"] == 1.0
    assert data["robots"]["toybot"]["all"]["typed_f1"] == 1.0


@pytest.mark.parametrize("line, message", [
    ("{id: x, classes: [Arm], side: up, roots: [], joints: [l_shoulder]}", "side 'up'"),
    ("{id: x, classes: [Arm], roots: [], joints: [wheel_l_joint]}", "also in part"),
    ("{id: x, classes: [Arm], roots: [], joints: [tilt_joint]}", "ignored joints"),
    ("{id: x, classes: [], roots: [], joints: [l_shoulder]}", "no accepted class"),
    ("{id: base, classes: [MobileBase], roots: [], links: [bumper]}", "duplicate body part ids"),
])
def test_truth_body_errors(tmp_path, line, message):
    path = tmp_path / "bad.yaml"
    path.write_text(TRUTH + f"    - {line}\n")
    with pytest.raises(ValueError, match=message):
        load_truth(path)


def test_truth_part_without_joints_needs_links(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(TRUTH.replace("joints: [], links: [base_link]", "joints: []"))
    with pytest.raises(ValueError, match="needs links"):
        load_truth(path)


def test_through_population_with_a_wheel_under_the_base(tmp_path):
    """The graph the pipeline writes: owlready2 individuals, side as a typed literal, the core taxonomy
    (which has no PanTiltHead: the head is a Head there, accepted by this truth)."""
    path = tmp_path / "toybot.yaml"
    path.write_text(TRUTH.replace("[PanTiltHead]", "[PanTiltHead, Head]"))
    truth = load_truth(path)
    parts = tuple(BodyPart(name, "Head" if name == "head" else p["cls"], 0.9, p["root"], tuple(p["joints"]),
                           tuple(p["links"]), p["side"], p["parent"]) for name, p in PERFECT.items())
    g = robot_graph(build_robot(owlready2.World(), TREE, "toybot", Abstraction(body=parts)))
    wheel = next(p for p in read_body(g) if p.cls == "Wheel" and p.side == "left")
    assert (wheel.joints, wheel.root) == ({"wheel_l_joint"}, "base_link")
    [holder] = g.subjects(CORE.hasComponent, rdflib.URIRef(wheel.node))
    assert (holder, RDF.type, CORE.MobileBase) in g                     # reached through the base, not the robot
    s = score(truth, g, LEAVES, TREE)[BODY]
    assert all(s[m] == 1.0 for m in BODY_METRICS), s


needs_shared = pytest.mark.skipif(not SHARED.is_dir(), reason=f"shared assets not found at {SHARED}")
TRUTH_FILES = sorted((SHARED / "eval" / "truth").glob("*.yaml")) if SHARED.is_dir() else []


@needs_shared
@pytest.mark.parametrize("path", TRUTH_FILES, ids=lambda p: p.stem)
def test_shared_truth_body_sections(path):
    """Each truth file has a body section whose parts split the scored joints of its URDF exactly,
    and a perfect prediction built from it (through population) scores 1."""
    truth = load_truth(path)
    assert truth.body is not None, "no body section"
    tree = load_urdf(SHARED / truth.urdf)
    listed = [j for p in truth.body.parts for j in p.joints]
    assert sorted(listed) == sorted(scored_joints(truth, tree))
    edges = {e.joint: e for e in tree.edges}
    parts = []
    for p in truth.body.parts:
        assert p.roots | set(p.links) <= set(tree.links), p.id
        tops = [edges[j].parent for j in p.joints if edges[j].parent not in {edges[k].child for k in p.joints}]
        root = min(tops, key=lambda link: len(tree.chain_to_root(link))) if tops else None
        assert root is None or root in p.roots, p.id
        links = p.links or tuple(edges[j].child for j in sorted(p.joints))
        parts.append(BodyPart(p.id, sorted(p.classes)[0], 0.9, root, tuple(sorted(p.joints)), links, p.side))
    g = robot_graph(build_robot(owlready2.World(), tree, truth.robot, Abstraction(body=tuple(parts))))
    s = score(truth, g, set(tree.leaves()), tree)[BODY]
    assert all(s[m] in (1.0, None) for m in BODY_METRICS), s
    empty = score(truth, robot_graph(build_robot(owlready2.World(), tree, truth.robot, None)), set(tree.leaves()), tree)
    assert empty[BODY]["typed_f1"] == (0.0 if truth.body.parts else 1.0)
