"""Suction tools whose links say nothing: what the file says of them elsewhere (a mesh, a simulator's vacuum
plugin naming the cup) finds them, whatever the model prefers for an opaquely named leaf."""
from __future__ import annotations

import random

import pytest

from tests.scripted_reasoner import scripted_placements, scripted_reasoner
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.reading.ingest import load_urdf

# (plugin library, the element naming the cup): the ROS 1 vacuum gripper, a ROS 2 simulation's own
PLUGINS = [("libgazebo_ros_vacuum_gripper.so", "bodyName"), ("libVacuumGripperPlugin.so", "gripper_link")]


def _arm_with_cup(seed: int, plugin: tuple[str, str] | None, mesh: str = "",
                  contact: bool = False) -> tuple[bytes, str, str]:
    """A six-joint arm of meaningless names whose last link carries a cup body (a flat cylinder, or `mesh`).
    Without `contact`, the cup carries the tool centre point; with it, the cup is a leaf on which the file declares
    a contact sensor (as simulated vacuum grippers do), beside the arm's massless tool frame (z out, REP 103).
    The URDF, the cup, and the other leaf."""
    w = Writer(random.Random(seed))
    link = w.link('<cylinder radius="0.08" length="0.1"/>')
    for i in range(6):
        nxt = w.link('<box size="0.06 0.06 0.2"/>')
        w.joint("revolute", link, nxt, (0.0, 0.0, 0.2 if i % 2 else 0.1), (0.0, float(i % 2), float(1 - i % 2)),
                (-3.0, 3.0))
        link = nxt
    cup = w.link(f'<mesh filename="package://{w.name()}/meshes/{mesh}.stl"/>' if mesh
                 else '<cylinder radius="0.05" length="0.01"/>')
    w.joint("fixed", link, cup, (0.0, 0.0, 0.085))
    other = w.link()
    if contact:
        w.joint("fixed", link, other, (0.0, 0.0, 0.08), rpy=(-1.5708, 0.0, -1.5708))
    else:
        w.joint("fixed", cup, other, (0.0, 0.0, 0.01))
    blocks = ""
    if plugin:
        library, tag = plugin
        blocks += (f'<gazebo><plugin name="{w.name()}" filename="{library}"><{tag}>{cup}</{tag}>'
                   f'<maxForce>50</maxForce></plugin></gazebo>')
    if contact:
        blocks += (f'<gazebo reference="{cup}"><sensor name="{w.name()}" type="contact">'
                   '<update_rate>10</update_rate></sensor></gazebo>')
    return w.urdf().replace(b"</robot>", blocks.encode() + b"</robot>"), cup, other


def _sensor_first(q):
    """The real model's mistake on an opaquely named leaf at an arm's end: a sensor (0.36 to 0.74 on public arms
    with vacuum cups)."""
    return "sensor" if "sensor" in q.options else q.options[0]


def _abstract(urdf: bytes):
    abstractor = Abstractor(Oracle(ScriptedBackend(_sensor_first)), vocabulary(), reasoner=scripted_reasoner,
                            placer=scripted_placements)
    return abstractor.run(load_urdf(urdf)).components


@pytest.mark.parametrize("plugin", PLUGINS)
def test_a_plugin_naming_a_link_gives_it_its_library_and_a_sensors_plugin_does_not(plugin):
    urdf, cup, tcp = _arm_with_cup(3, plugin)
    stem = plugin[0].removeprefix("lib").removesuffix(".so")
    tree = load_urdf(urdf)
    assert tree.evidence[cup].plugins == (stem,) and tree.evidence[tcp].plugins == ()
    inside = urdf.replace(b"<gazebo><plugin", b'<gazebo reference="%s"><sensor type="contact"><plugin' % cup.encode())
    inside = inside.replace(b"</plugin></gazebo>", b"</plugin></sensor></gazebo>")
    assert load_urdf(inside).evidence[cup].plugins == ()


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("plugin, mesh, contact", [(PLUGINS[0], "", False), (PLUGINS[1], "", True),
                                                   (None, "vacuum_cup", False)])
def test_a_cup_the_file_calls_a_vacuum_gripper_is_the_arms_suction_gripper(seed, plugin, mesh, contact):
    """The cup's name says nothing; a vacuum plugin naming it, or its mesh, calls it a vacuum gripper (the
    catalogue's generic product). A model that calls every leaf a sensor still gets one suction gripper holding the
    cup and the leaf beside or below it: a tool centre point, or the arm's tool frame beside a cup the simulator
    senses contact on (frames of one body, of the kind of the product one of them names)."""
    urdf, cup, other = _arm_with_cup(seed, plugin, mesh, contact)
    components = _abstract(urdf)
    assert not [c for c in components if c.kind == "sensor"]
    (tool,) = [c for c in components if c.kind == "end_effector"]
    assert tool.cls == "SuctionGripper" and {cup, other} <= set(tool.links), (tool.cls, tool.links)


@pytest.mark.parametrize("seed", range(4))
def test_a_camera_the_file_declares_beside_a_named_cup_stays_a_camera(seed):
    """The frame beside the cup is a camera the file declares (an optical frame with a simulator camera on it): the
    cup's product does not make it part of the suction gripper."""
    urdf, cup, frame = _arm_with_cup(seed, None, "vacuum_cup", contact=True)
    urdf = urdf.replace(f'<gazebo reference="{cup}"><sensor'.encode(), f'<gazebo reference="{frame}"><sensor'.encode())
    urdf = urdf.replace(b'type="contact"', b'type="camera"')
    components = _abstract(urdf)
    assert any(frame in c.links for c in components if c.kind == "sensor"), [(c.cls, c.links) for c in components]


@pytest.mark.parametrize("seed", range(4))
def test_a_vacuum_plugin_naming_the_flange_names_no_body_bolted_beside_it(seed):
    """A vacuum plugin names the arm's last link (as some files attach it to a flange or a finger), which carries
    the cup and, beside it, a camera housing of an opaque name: the housing is not thereby a suction gripper (the
    model's sensor stands)."""
    urdf, cup, _ = _arm_with_cup(seed, PLUGINS[0])
    flange = load_urdf(urdf).parent(cup)
    urdf = urdf.replace(f"<bodyName>{cup}</bodyName>".encode(), f"<bodyName>{flange}</bodyName>".encode())
    housing = '<link name="qoxuvi"><visual><geometry><box size="0.03 0.09 0.03"/></geometry></visual></link>' \
              f'<joint name="qoxuvi_joint" type="fixed"><parent link="{flange}"/><child link="qoxuvi"/>' \
              '<origin xyz="0.06 0 0.02" rpy="0 0 0"/></joint>'
    components = _abstract(urdf.replace(b"</robot>", housing.encode() + b"</robot>"))
    assert [c.cls for c in components if "qoxuvi" in c.links] == ["MonocularCamera"], \
        [(c.cls, c.links) for c in components]
