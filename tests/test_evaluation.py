"""Accuracy metrics on hand-built graphs, and a guard on the shared truth data."""
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import rdflib
import yaml
from rdflib import RDF, RDFS

from urdfkb.pipeline.scoring.component_scoring import METRICS, SCOPES
from urdfkb.pipeline.scoring.evaluation import failed_scores, fold_means, mean_scores, score
from urdfkb.pipeline.scoring.evaluation_report import format_table, review_queue
from urdfkb.pipeline.knowledge.namespaces import CORE
from urdfkb.pipeline.scoring.prediction import read_prediction
from urdfkb.pipeline.scoring.truth import load_truth

HIERARCHY = {
    "Sensor": ["Component"], "EndEffector": ["Component"],
    "VisionSensor": ["Sensor"], "Camera": ["VisionSensor"], "StereoCamera": ["Camera"],
    "AudioSensor": ["Sensor"], "SensorArray": ["Sensor"], "Microphone": ["AudioSensor"],
    "MicrophoneArray": ["SensorArray", "AudioSensor"],
    "Gripper": ["EndEffector"], "ParallelGripper": ["Gripper"],
    "SensorSubpart": ["Subpart"], "OpticalFrame": ["SensorSubpart"], "RgbFrame": ["OpticalFrame"],
    "EndEffectorSubpart": ["Subpart"], "Finger": ["EndEffectorSubpart"], "ToolCenterPoint": ["EndEffectorSubpart"],
}
MICS = ["mic_fl", "mic_fr", "mic_bl", "mic_br"]
URDF_LEAVES = {"cam_l", "cam_r", "cam_c", *MICS, "tip", "tcp", "projector", "wheel"}
TRUTH = """
robot: toy
urdf: urdf/toy.urdf
ignore: [projector]
components:
  - id: stereo
    kind: sensor
    classes: [StereoCamera]
    roots: [head]
    leaves: [cam_c, cam_l, cam_r]
    subparts: {cam_l: [RgbFrame], cam_r: [RgbFrame]}
  - {id: mics, kind: sensor, classes: [MicrophoneArray], roots: [base], leaves: [mic_fl, mic_fr, mic_bl, mic_br]}
  - id: gripper
    kind: end_effector
    classes: [ParallelGripper]
    roots: [wrist]
    leaves: [tip, tcp]
    subparts: {tip: [Finger], tcp: [ToolCenterPoint]}
alternatives:
  - replace: [mics]
    with:
""" + "".join(f"      - {{id: {m}, kind: sensor, classes: [Microphone], roots: [base], leaves: [{m}]}}\n" for m in MICS)

STEREO = ("StereoCamera", "head", {"cam_c": "OpticalFrame", "cam_l": "RgbFrame", "cam_r": "RgbFrame"})
ARRAY = ("MicrophoneArray", "base", {m: None for m in MICS})
GRIPPER = ("ParallelGripper", "wrist", {"tip": "Finger", "tcp": "ToolCenterPoint"})
PERFECT = [STEREO, ARRAY, GRIPPER]


def graph(components) -> rdflib.Graph:
    """A populated robot: each component is (class, root link, {leaf: subpart class or None});
    a None subpart links the leaf straight from the component."""
    g = rdflib.Graph()
    for sub, sups in HIERARCHY.items():
        for sup in sups:
            g.add((CORE[sub], RDFS.subClassOf, CORE[sup]))
    robot = CORE.toy
    g.add((robot, RDF.type, CORE.Robot))

    def link(name):
        node = CORE["link_" + name]
        g.add((node, RDF.type, CORE.Link))
        g.add((node, CORE.urdfName, rdflib.Literal(name)))
        return node

    for i, (cls, root, leaves) in enumerate(components):
        comp = CORE[f"c{i}"]
        g.add((robot, CORE.hasComponent, comp))
        g.add((comp, RDF.type, CORE[cls]))
        g.add((comp, CORE.isMountedOn, link(root)))
        for leaf, sub_cls in leaves.items():
            if sub_cls is None:
                g.add((comp, CORE.hasLink, link(leaf)))
                continue
            sub = CORE[f"c{i}_{leaf}"]
            g.add((comp, CORE.hasComponent, sub))
            g.add((sub, RDF.type, CORE[sub_cls]))
            g.add((sub, CORE.hasLink, link(leaf)))
    return g


@pytest.fixture
def truth(tmp_path):
    path = tmp_path / "toy.yaml"
    path.write_text(TRUTH)
    return load_truth(path)


def run(truth, components):
    return score(truth, graph(components), URDF_LEAVES)


def test_perfect_prediction_scores_one_everywhere(truth):
    s = run(truth, PERFECT)
    for scope in SCOPES:
        assert all(s[scope][m] == 1.0 for m in METRICS), (scope, s[scope])
    assert s["partitions"] == {"mics": "canonical"}
    assert (s["all"]["n_matched"], s["all"]["n_subparts"]) == (3, 4)


def test_read_prediction_reads_kind_class_root_leaves_and_subparts():
    preds = {p.cls: p for p in read_prediction(graph([STEREO, GRIPPER]), URDF_LEAVES)}
    stereo = preds["StereoCamera"]
    assert (stereo.kind, stereo.root, stereo.leaves) == ("sensor", "head", {"cam_c", "cam_l", "cam_r"})
    assert stereo.subparts == {"cam_c": "OpticalFrame", "cam_l": "RgbFrame", "cam_r": "RgbFrame"}
    assert preds["ParallelGripper"].kind == "end_effector"


def test_most_specific_class_and_non_component_individuals():
    g = graph([STEREO, ("Camera", "base", {"wheel": None})])
    g.add((CORE.c0, RDF.type, CORE.Camera))                        # a redundant ancestor type
    g.add((CORE.c0, RDF.type, rdflib.OWL.NamedIndividual))
    g.add((CORE.toy, CORE.hasComponent, CORE.body))                # not a sensor / end-effector
    g.add((CORE.body, RDF.type, CORE.Component))
    g.add((CORE.body, CORE.hasLink, CORE.link_wheel))
    preds = read_prediction(g, URDF_LEAVES)
    assert sorted(str(p.cls) for p in preds) == ["Camera", "StereoCamera"]


def test_merged_and_split_groups(truth):
    merged = ("StereoCamera", "head", {"cam_c": None, "cam_l": None, "cam_r": None, "tip": None})
    split = [("Gripper", "wrist", {"tip": None}), ("Gripper", "wrist", {"tcp": None})]
    s = run(truth, [merged, ARRAY, *split])
    a = s["all"]
    assert (a["n_predicted"], a["n_truth"], a["n_matched"]) == (4, 3, 1)
    assert a["component_precision"] == pytest.approx(1 / 4)
    assert a["component_recall"] == pytest.approx(1 / 3)
    assert a["component_f1"] == pytest.approx(2 / 7)
    assert a["leaf_f1"] == 1.0                                      # same leaves, other grouping
    ee = s["end_effector"]
    assert (ee["component_f1"], ee["leaf_recall"], ee["leaf_precision"]) == (0.0, 1.0, 1.0)
    sensor = s["sensor"]
    assert sensor["leaf_precision"] == pytest.approx(7 / 8)          # 'tip' labelled as a sensor
    assert sensor["component_precision"] == sensor["component_recall"] == 0.5


def test_differences_name_each_miss_extra_type_root_and_subpart(truth):
    assert run(truth, PERFECT)["differences"] == []
    merged = ("Camera", "base", {"cam_c": None, "cam_l": None, "cam_r": "OpticalFrame", "tip": None})
    gripper = ("ParallelGripper", "wrist", {"tip": "Finger", "tcp": "EndEffectorSubpart"})
    assert sorted(run(truth, [("Camera", "base", STEREO[2]), gripper, merged])["differences"]) == [
        "extra Camera (sensor) on base: ['cam_c', 'cam_l', 'cam_r', 'tip']",
        "missed mics (sensor, MicrophoneArray): ['mic_bl', 'mic_br', 'mic_fl', 'mic_fr']",
        "root of stereo base, truth head",
        "subpart tcp of gripper EndEffectorSubpart, truth ToolCenterPoint",
        "typed stereo Camera, truth StereoCamera (credit 0.5)",
    ]


def test_strict_ancestor_class_gets_half_credit(truth):
    camera = ("Camera", "head", STEREO[2])
    sensor = ("Sensor", "base", ARRAY[2])                          # not strictly below Sensor
    s = run(truth, [camera, sensor, GRIPPER])
    assert s["sensor"]["component_f1"] == 1.0
    assert s["sensor"]["typed_f1"] == pytest.approx(0.25)            # (0.5 + 0) / 2
    assert s["all"]["typed_precision"] == pytest.approx(1.5 / 3)
    assert s["end_effector"]["typed_f1"] == 1.0


def test_wrong_root(truth):
    s = run(truth, [("StereoCamera", "base", STEREO[2]), ARRAY, GRIPPER])
    assert s["sensor"]["root_accuracy"] == 0.5
    assert s["all"]["root_accuracy"] == pytest.approx(2 / 3)
    assert s["all"]["typed_f1"] == 1.0


@pytest.mark.parametrize("mics, chosen, matched", [
    ([("Microphone", "base", {m: None}) for m in MICS], "alternative", 5),
    ([ARRAY], "canonical", 2),
    ([("Microphone", "base", {"mic_fl": None})], "alternative", 2),       # 1 of 4 beats 0 of 1
    ([("MicrophoneArray", "base", {"mic_fl": None, "mic_fr": None})], "canonical", 1),  # tie
])
def test_alternatives_pick_the_partition_matching_more(truth, mics, chosen, matched):
    s = run(truth, [STEREO, *mics])
    assert s["partitions"] == {"mics": chosen}
    assert s["sensor"]["n_matched"] == matched
    assert s["sensor"]["n_truth"] == (5 if chosen == "alternative" else 2)


def test_four_microphones_score_perfectly(truth):
    s = run(truth, [STEREO, GRIPPER, *[("Microphone", "base", {m: None}) for m in MICS]])
    assert all(s["all"][m] == 1.0 for m in METRICS)


def test_ignored_leaves_are_unscored(truth):
    projector_only = ("Camera", "head", {"projector": None})
    with_projector = ("StereoCamera", "head", {**STEREO[2], "projector": None})
    s = run(truth, [with_projector, ARRAY, GRIPPER, projector_only])
    assert s["all"]["n_predicted"] == 3                              # the projector-only camera is dropped
    assert all(s["all"][m] == 1.0 for m in METRICS)


def test_cross_kind_match_is_a_miss_in_both_kinds(truth):
    s = run(truth, [STEREO, ARRAY, ("Camera", "wrist", GRIPPER[2])])
    assert s["sensor"]["n_predicted"] == 3 and s["sensor"]["component_precision"] == pytest.approx(2 / 3)
    assert s["end_effector"]["component_recall"] == 0.0
    assert s["all"]["component_f1"] == 1.0 and s["all"]["typed_f1"] == pytest.approx(2 / 3)


def test_empty_prediction(truth):
    s = run(truth, [])
    for scope in SCOPES:
        assert all(s[scope][m] == 0.0 for m in METRICS)
        assert s[scope]["n_predicted"] == s[scope]["n_matched"] == 0
    assert s["all"]["n_truth"] == 3


def test_subpart_accuracy_with_ancestor(truth):
    stereo = ("StereoCamera", "head", {"cam_c": None, "cam_l": "OpticalFrame", "cam_r": "SensorSubpart"})
    gripper = ("ParallelGripper", "wrist", {"tip": "Finger", "tcp": None})     # no sub-component for tcp
    s = run(truth, [stereo, ARRAY, gripper])
    assert s["sensor"]["subpart_accuracy"] == pytest.approx(0.25)    # (0.5 + 0) / 2
    assert s["end_effector"]["subpart_accuracy"] == 0.5
    assert s["all"]["subpart_accuracy"] == pytest.approx(1.5 / 4)
    assert s["all"]["n_subparts"] == 4


def test_failed_mean_and_table(truth):
    per_robot = {"toy": run(truth, PERFECT), "broken": failed_scores()}
    mean = mean_scores(per_robot)
    assert mean["all"]["typed_f1"] == 0.5 and mean["failed"] == 1
    assert mean["sensor"]["n_truth"] == 2
    table = format_table(per_robot, {"LLM calls": {"toy": 12, "mean": 6}})
    assert "TYPED_F1" in table and "broken (failed)" in table
    lines = table.splitlines()
    assert any(line.startswith("mean") and "0.500" in line for line in lines)
    assert any(line.startswith("toy") and line.rstrip().endswith("12") for line in lines)


def urdf_links(path):
    root = ET.parse(path).getroot()
    links = {link.get("name") for link in root.findall("link")}
    parents = {parent.get("link") for parent in root.findall("joint/parent")}
    return links, links - parents


@pytest.mark.parametrize("robot", ["pr2", "tiago", "pepper"])
def test_real_truth_files_name_urdf_leaves(shared, robot):
    truth = load_truth(shared / "eval" / "truth" / f"{robot}.yaml")
    assert truth.robot == robot
    links, leaves = urdf_links(shared / truth.urdf)
    comps = [*truth.components, *(c for alt in truth.alternatives for c in alt.with_)]
    assert comps
    for c in comps:
        assert c.leaves <= leaves - truth.ignore, (c.id, c.leaves - leaves)
        assert c.roots <= links, (c.id, c.roots - links)
    assert truth.ignore <= leaves
    canonical = [c.leaves for c in truth.components]
    assert sum(map(len, canonical)) == len(set().union(*canonical)), "truth components overlap"
    for alt in truth.alternatives:
        replaced = set().union(*(c.leaves for c in truth.components if c.id in alt.replace))
        assert set().union(*(c.leaves for c in alt.with_)) == replaced, alt.replace


def test_a_kind_the_robot_lacks_scores_one_unless_predicted(tmp_path):
    path = tmp_path / "rover.yaml"  # a robot with sensors only, no subparts listed
    path.write_text("robot: rover\nurdf: urdf/rover.urdf\nignore: []\ncomponents:\n"
                    "  - {id: mics, kind: sensor, classes: [MicrophoneArray], roots: [base], leaves: [mic_fl, mic_fr, mic_bl, mic_br]}\n")
    rover = load_truth(path)
    quiet = score(rover, graph([ARRAY]), URDF_LEAVES)
    assert quiet["end_effector"]["typed_f1"] == quiet["end_effector"]["component_f1"] == 1.0
    assert quiet["end_effector"]["root_accuracy"] is None and quiet["all"]["subpart_accuracy"] is None
    noisy = score(rover, graph([ARRAY, GRIPPER]), URDF_LEAVES)
    assert noisy["end_effector"]["typed_precision"] == noisy["end_effector"]["typed_f1"] == 0.0
    mean = mean_scores({"quiet": quiet, "noisy": noisy})
    assert mean["end_effector"]["root_accuracy"] is None and mean["end_effector"]["typed_f1"] == 0.5
    assert "-" in format_table({"quiet": quiet})


def test_each_fold_gets_its_mean_row(truth):
    per_robot = {"toy": run(truth, PERFECT), "broken": failed_scores(), "other": run(truth, PERFECT)}
    folds = {"A": ["toy", "other", "not_run"], "B": ["broken"]}
    means = fold_means(per_robot, folds)
    assert means["A"]["all"]["typed_f1"] == 1.0 and means["B"]["all"]["typed_f1"] == 0.0
    lines = format_table(per_robot, folds=folds).splitlines()
    assert any(line.startswith("mean A") and "1.000" in line for line in lines)
    assert any(line.startswith("mean B") and "0.000" in line for line in lines)


def test_the_folds_split_every_truth_robot_by_family(shared):
    """Every truth robot in exactly one fold, and no family in both (benchmarks/folds.yaml)."""
    data = yaml.safe_load((Path(__file__).parents[1] / "benchmarks" / "folds.yaml").read_text())
    robots = [r for fold in data.values() for r in fold]
    assert sorted(robots) == sorted(p.stem for p in (shared / "eval" / "truth").glob("*.yaml"))
    families = [{family for family in fold.values()} for fold in data.values()]
    assert not set.intersection(*families)


def test_the_review_queue_is_measured_against_what_is_wrong(truth):
    """A wrong component (a stereo camera typed Camera: half credit) below the threshold and a right one above it:
    the queue holds every wrong component and takes one of three."""
    g = graph([("Camera", "head", STEREO[2]), ARRAY, GRIPPER])
    for node, confidence in ((CORE.c0, 0.3), (CORE.c1, 0.9), (CORE.c2, 0.8)):
        g.add((node, CORE.confidence, rdflib.Literal(confidence)))
    s = score(truth, g, URDF_LEAVES)
    assert (s["all"]["n_wrong"], s["all"]["n_queued"], s["all"]["n_wrong_queued"]) == (1, 1, 1)
    line = review_queue(mean_scores({"toy": s, "again": s}))
    assert "holds 100% of the 2 wrong components (2), takes 33% of the 6 predicted (2)" in line
