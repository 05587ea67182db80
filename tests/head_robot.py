"""A head with a camera and a laser on fixed joints, and a model that calls every leaf a sensor: a run
with no finger chain and no movable joint, so no reasoner run."""
from __future__ import annotations

from urdfkb.pipeline.llm.base import Question

HEAD = """<robot name="head">
  <link name="base_link"/><link name="mast"/><link name="cam_link"/><link name="cam_optical_frame"/><link name="laser"/>
  <joint name="j0" type="fixed"><parent link="base_link"/><child link="mast"/></joint>
  <joint name="j1" type="fixed"><parent link="mast"/><child link="cam_link"/></joint>
  <joint name="j2" type="fixed"><parent link="cam_link"/><child link="cam_optical_frame"/></joint>
  <joint name="j3" type="fixed"><parent link="base_link"/><child link="laser"/></joint>
</robot>"""


def perfect(question: Question) -> str:
    """Every leaf is a sensor; otherwise the first option."""
    return "sensor" if "sensor" in question.options and question.key.startswith("identify:") else question.options[0]
