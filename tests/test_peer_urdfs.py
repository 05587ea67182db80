"""urdfdom's own test assets: each file either ingests or is refused with a URDFError.

VERDICTS is our explicit choice per file, with the refusal message we expect and why.
We follow urdfdom (EXPECTED.tsv) on every file: a document ROS itself cannot load is not
one we describe, and where urdfdom builds the model we do too. Files urdfdom parses but with
an invalid visual dropped ingest the same way: we drop that visual before yourdfpy (which
would crash on it); the kinematic tree never depended on it. DEVIATIONS lists files where
we differ from urdfdom; it is empty.
"""
import csv

import pytest
from tests.shared_assets import SHARED

from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.ingest import load_urdf

INGEST, REFUSE = "parse", "fail"  # spelled as EXPECTED.tsv's urdfdom_expects

# file: (verdict, refusal message fragment or root link when ingested, reason)
VERDICTS = {
    "bad_box_no_size.urdf": (INGEST, "base", "urdfdom drops the invalid visual; so do we"),
    "bad_cylinder_no_length.urdf": (INGEST, "base", "urdfdom drops the invalid visual; so do we"),
    "bad_cylinder_no_radius.urdf": (INGEST, "base", "urdfdom drops the invalid visual; so do we"),
    "bad_mesh_no_filename.urdf": (INGEST, "base", "urdfdom drops the invalid visual; so do we"),
    "bad_sphere_no_radius.urdf": (INGEST, "base", "urdfdom drops the invalid visual; so do we"),
    "bad_unknown_geometry_type.urdf": (INGEST, "base", "urdfdom drops the torus visual; so do we"),
    "bad_duplicate_joint_name.urdf": (REFUSE, "duplicate joint name 'j1'", "joint names must identify joints"),
    "bad_duplicate_link_name.urdf": (REFUSE, "duplicate link name 'base'", "link names must identify links"),
    "bad_duplicate_material.urdf": (REFUSE, "duplicate global material 'red'", "ambiguous colour; ROS refuses it"),
    "bad_dynamics_empty.urdf": (REFUSE, "needs one of damping or friction", "ROS refuses it; likely a broken xacro"),
    "bad_invalid_xml.urdf": (REFUSE, "not XML", "not well-formed"),
    "bad_joint_no_type.urdf": (REFUSE, "joint has no type", "the type decides what the joint is"),
    "bad_joint_unknown_child.urdf": (REFUSE, "unknown child link 'nonexistent'", "dangling joint"),
    "bad_joint_unknown_parent.urdf": (REFUSE, "unknown parent link 'nonexistent'", "dangling joint"),
    "bad_limit_effort_not_number.urdf": (REFUSE, "effort='not_a_number' is not a number", "malformed joint data"),
    "bad_limit_no_effort.urdf": (REFUSE, "lacks required attribute 'effort'", "malformed joint data"),
    "bad_limit_no_velocity.urdf": (REFUSE, "lacks required attribute 'velocity'", "malformed joint data"),
    "bad_limit_velocity_not_number.urdf": (REFUSE, "velocity='fast' is not a number", "malformed joint data"),
    "bad_malformed_version.urdf": (REFUSE, "malformed version 'one.zero'", "unknown format"),
    "bad_mimic_no_joint_name.urdf": (REFUSE, "<mimic> lacks required attribute 'joint'", "coupling to nothing"),
    "bad_no_links.urdf": (REFUSE, "robot has no links", "no tree"),
    "bad_no_robot_element.urdf": (REFUSE, "root element is <not_a_robot>", "not a URDF"),
    "bad_prismatic_no_limits.urdf": (REFUSE, "prismatic joint has no <limit>", "URDF requires the limit"),
    "bad_revolute_no_limits.urdf": (REFUSE, "revolute joint has no <limit>", "URDF requires the limit"),
    "bad_robot_no_name.urdf": (REFUSE, "<robot> has no name", "the robot needs an identity"),
    "bad_safety_no_k_velocity.urdf": (REFUSE, "lacks required attribute 'k_velocity'", "ROS refuses it"),
    "bad_two_root_links.urdf": (REFUSE, "several root links: root1, root2", "not one tree"),
    "bad_unknown_joint_type.urdf": (REFUSE, "unknown joint type 'spring'", "unknown motion"),
    "bad_version_too_high.urdf": (REFUSE, "unsupported URDF version '2.0'", "format we cannot read"),
    "bad_version_too_low.urdf": (REFUSE, "unsupported URDF version '0.9'", "format we cannot read"),
    "branching_robot.urdf": (INGEST, "torso", "valid"),
    "full_robot_v1_0.urdf": (INGEST, "base_link", "valid, every v1.0 feature"),
    "global_material.urdf": (INGEST, "base", "valid"),
    "inertial_link.urdf": (INGEST, "base", "valid"),
    "multiple_geometries.urdf": (INGEST, "base", "valid"),
    "revolute_joint.urdf": (INGEST, "l1", "valid"),
    "three_link_chain.urdf": (INGEST, "base", "valid"),
}
DEVIATIONS: dict[str, str] = {}
PEER_FILES = sorted(p.name for p in (SHARED / "urdf-peer-tests").glob("*.urdf")) or ["<urdf-peer-tests missing>"]


def urdfdom_expects(shared):
    with open(shared / "urdf-peer-tests" / "EXPECTED.tsv", newline="") as handle:
        return {row["file"]: row["urdfdom_expects"] for row in csv.DictReader(handle, delimiter="\t")}


def test_every_peer_file_has_a_verdict(shared):
    assert set(VERDICTS) == {p.name for p in (shared / "urdf-peer-tests").glob("*.urdf")}


def test_verdicts_follow_urdfdom_except_deviations(shared):
    expected = urdfdom_expects(shared)
    differing = {name for name, (verdict, _, _) in VERDICTS.items() if verdict != expected[name]}
    assert differing == set(DEVIATIONS)


@pytest.mark.parametrize("name", PEER_FILES)
def test_peer_file(shared, name):
    verdict, detail, _reason = VERDICTS[name]
    path = shared / "urdf-peer-tests" / name
    if verdict == INGEST:
        assert load_urdf(path).root == detail
    else:
        with pytest.raises(URDFError) as info:
            load_urdf(path)
        assert detail in str(info.value)
