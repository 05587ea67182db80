"""KinematicTree: operations on small hand-built trees and on every real robot in shared/urdf."""
import csv
import math
import random

import pytest
import trimesh.transformations as tra
import yourdfpy
from tests.shared_assets import SHARED

from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin, TreeError

ZERO = Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
REAL_FILES = sorted(p.name for p in (SHARED / "urdf").glob("*.urdf")) or ["<shared/urdf missing>"]


def edge(joint, parent, child, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0), kind="fixed"):
    return Edge(joint, kind, parent, child, Origin(xyz, rpy))


@pytest.fixture
def small():
    """base -> arm -> hand -> finger_b, hand -> finger_a ; base -> head ; the doc order differs from names."""
    return KinematicTree(
        "small",
        ("base", "head", "arm", "hand", "finger_b", "finger_a"),
        (
            edge("j_arm", "base", "arm", xyz=(1.0, 0.0, 0.0), rpy=(0.0, 0.0, math.pi / 2), kind="revolute"),
            edge("j_hand", "arm", "hand", xyz=(2.0, 0.0, 0.0)),
            edge("j_fb", "hand", "finger_b", xyz=(0.0, 0.0, 0.5)),
            edge("j_head", "base", "head", xyz=(0.0, 0.0, 1.0)),
            edge("j_fa", "hand", "finger_a"),
        ),
    )


def assert_close(actual, expected, tol=1e-9):
    assert all(math.isclose(a, e, abs_tol=tol) for a, e in zip(actual, expected, strict=True)), (actual, expected)


# -- small trees ---------------------------------------------------------------------------


def test_navigation(small):
    assert small.root == "base"
    assert small.parent("hand") == "arm" and small.parent("base") is None
    assert small.parent_edge("hand").joint == "j_hand" and small.parent_edge("base") is None
    assert small.children("base") == ("arm", "head")
    assert small.children("hand") == ("finger_b", "finger_a")
    assert small.leaves() == ("head", "finger_b", "finger_a")
    assert small.is_leaf("head") and not small.is_leaf("arm")
    assert small.chain_to_root("finger_a") == ("finger_a", "hand", "arm", "base")
    assert small.chain_to_root("base") == ("base",)


def test_descendants_are_depth_first_in_document_order(small):
    assert small.descendants("base") == ("arm", "hand", "finger_b", "finger_a", "head")
    assert small.descendants("hand") == ("finger_b", "finger_a")
    assert small.descendants("head") == ()


def test_position_in_composes_translation_and_rotation(small):
    # arm is yawed 90 degrees, so hand's x offset of 2 points along base's y axis.
    assert_close(small.position_in("hand", "base"), (1.0, 2.0, 0.0))
    assert_close(small.position_in("finger_b", "base"), (1.0, 2.0, 0.5))
    assert_close(small.position_in("finger_b", "arm"), (2.0, 0.0, 0.5))
    assert small.position_in("hand", "hand") == (0.0, 0.0, 0.0)


def test_direction_in_turns_a_direction_without_moving_it(small):
    # arm is yawed 90 degrees: hand's x axis points along base's y axis, wherever hand lies.
    assert_close(small.direction_in("hand", "base", (1.0, 0.0, 0.0)), (0.0, 1.0, 0.0))
    assert_close(small.direction_in("hand", "arm", (1.0, 0.0, 0.0)), (1.0, 0.0, 0.0))


def test_position_in_uses_urdf_rpy_convention():
    """R = Rz(yaw) Ry(pitch) Rx(roll), checked against trimesh's static-xyz Euler matrices."""
    rng = random.Random(7)
    for _ in range(50):
        rpy = tuple(rng.uniform(-math.pi, math.pi) for _ in range(3))
        offset = tuple(rng.uniform(-1, 1) for _ in range(3))
        tree = KinematicTree("r", ("a", "b", "c"), (edge("j1", "a", "b", rpy=rpy), edge("j2", "b", "c", xyz=offset)))
        expected = tra.euler_matrix(rpy[0], rpy[1], rpy[2], "sxyz")[:3, :3] @ offset
        assert_close(tree.position_in("c", "a"), expected)


def test_position_in_refuses_a_non_ancestor(small):
    with pytest.raises(ValueError, match="not an ancestor"):
        small.position_in("head", "arm")
    with pytest.raises(ValueError):
        small.position_in("base", "hand")


@pytest.mark.parametrize(
    "call",
    [
        lambda t: t.parent("nope"),
        lambda t: t.parent_edge("nope"),
        lambda t: t.children("nope"),
        lambda t: t.is_leaf("nope"),
        lambda t: t.chain_to_root("nope"),
        lambda t: t.descendants("nope"),
        lambda t: t.position_in("nope", "base"),
        lambda t: t.position_in("hand", "nope"),
        lambda t: t.without({"nope"}),
    ],
)
def test_unknown_link_raises_key_error_naming_it(small, call):
    with pytest.raises(KeyError, match="nope"):
        call(small)


def test_without_prunes_closed_subtree(small):
    pruned = small.without({"hand", "finger_a", "finger_b"})
    assert pruned.links == ("base", "head", "arm")
    assert [e.joint for e in pruned.edges] == ["j_arm", "j_head"]
    assert pruned.leaves() == ("head", "arm")
    assert small.without(()) == small


def test_without_refuses_open_set_and_root(small):
    with pytest.raises(ValueError, match="finger_a"):
        small.without({"hand", "finger_b"})
    with pytest.raises(ValueError, match="root"):
        small.without(set(small.links))


def test_a_callers_lists_do_not_reach_into_the_tree(small):
    links, edges = list(small.links), list(small.edges)
    tree = KinematicTree(small.robot_name, links, edges)  # type: ignore[arg-type]  # lists, as an untyped caller may pass
    links.append("ghost")
    edges.pop()
    assert tree.links == small.links and tree.edges == small.edges and tree.leaves() == small.leaves()


def test_equal_trees_compare_and_hash_equal(small):
    again = KinematicTree(small.robot_name, small.links, small.edges)
    assert again == small and hash(again) == hash(small)


@pytest.mark.parametrize(
    "links, edges, message",
    [
        ((), (), "no links"),
        (("a", "b", "a"), (edge("j", "a", "b"),), "duplicate link name 'a'"),
        (("a", "b", "c"), (edge("j", "a", "b"), edge("j", "a", "c")), "duplicate joint name 'j'"),
        (("a",), (edge("j", "a", "ghost"),), "unknown child link 'ghost'"),
        (("a", "b", "c"), (edge("j1", "a", "c"), edge("j2", "b", "c")), "'c' has two parents"),
        (("a", "b", "c"), (edge("j", "a", "b"),), "several root links: a, c"),
        (("a", "b"), (edge("j1", "a", "b"), edge("j2", "b", "a")), "cycle"),
        (("r", "a", "b"), (edge("j1", "a", "b"), edge("j2", "b", "a")), "cycle through links"),
    ],
)
def test_construction_refuses_non_trees(links, edges, message):
    with pytest.raises(TreeError, match=message):
        KinematicTree("bad", links, edges)


def test_single_link_tree():
    tree = KinematicTree("one", ("only",), ())
    assert tree.root == "only" and tree.leaves() == ("only",) and tree.descendants("only") == ()


# -- every real robot ---------------------------------------------------------------------


def sources(shared):
    with open(shared / "urdf" / "SOURCES.tsv", newline="") as handle:
        return {row["file"]: row for row in csv.DictReader(handle, delimiter="\t")}


def test_sources_tsv_describes_exactly_the_directory(shared):
    assert set(sources(shared)) == {p.name for p in (shared / "urdf").glob("*.urdf")}


@pytest.fixture(scope="module")
def real_trees(shared):
    return {name: load_urdf(shared / "urdf" / name) for name in REAL_FILES}


@pytest.mark.parametrize("name", REAL_FILES)
def test_counts_match_sources(shared, real_trees, name):
    row, tree = sources(shared)[name], real_trees[name]
    assert (len(tree.links), len(tree.edges), len(tree.leaves())) == (
        int(row["n_links"]),
        int(row["n_joints"]),
        int(row["n_leaves"]),
    )


@pytest.mark.parametrize("name", REAL_FILES)
def test_structure_is_one_tree(real_trees, name):
    tree = real_trees[name]
    assert tree.parent(tree.root) is None
    assert sorted(tree.descendants(tree.root)) == sorted(set(tree.links) - {tree.root})
    for link in tree.links:
        chain = tree.chain_to_root(link)
        assert chain[0] == link and chain[-1] == tree.root and len(set(chain)) == len(chain)
        assert tree.is_leaf(link) == (link in tree.leaves())
        for child in tree.children(link):
            assert tree.parent(child) == link


@pytest.mark.parametrize("name", REAL_FILES)
def test_position_in_matches_yourdfpy_forward_kinematics(shared, real_trees, name):
    """Our composition of the origins as written equals yourdfpy's scene graph with every joint at
    zero (mimic offsets, which move a joint away from its origin at zero, are zeroed first)."""
    tree = real_trees[name]
    parsed = yourdfpy.URDF.load(str(shared / "urdf" / name), build_scene_graph=False, load_meshes=False)
    for joint in parsed.robot.joints:
        if joint.mimic is not None:
            joint.mimic.offset = 0.0
    model = yourdfpy.URDF(parsed.robot, build_scene_graph=True, load_meshes=False)
    for link in tree.links:
        assert_close(tree.position_in(link, tree.root), model.get_transform(link, tree.root)[:3, 3], tol=1e-7)
        edge_in = tree.parent_edge(link)
        if edge_in is not None:
            assert tree.position_in(link, edge_in.parent) == pytest.approx(edge_in.origin.xyz)


@pytest.mark.parametrize("name", REAL_FILES)
def test_without_a_subtree(real_trees, name):
    tree = real_trees[name]
    branch = max(tree.children(tree.root), key=lambda c: len(tree.descendants(c)))
    removed = {branch, *tree.descendants(branch)}
    pruned = tree.without(removed)
    assert len(pruned.links) == len(tree.links) - len(removed)
    assert len(pruned.edges) == len(pruned.links) - 1
    assert pruned.root == tree.root and not removed & set(pruned.links)
    if tree.descendants(branch):
        with pytest.raises(ValueError):
            tree.without({branch})
