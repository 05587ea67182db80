"""The review pages' colours come from kb_server.palette alone, keyed by what the ontology names."""
import re
from pathlib import Path

from urdfkb.kb_server import palette
from urdfkb.pipeline.knowledge.ontology import vocabulary

KB_SERVER = Path(__file__).resolve().parents[1] / "kb_server"


def test_every_kind_and_body_class_has_its_own_colour():
    tax = vocabulary()
    assert [s.key for s in palette.kinds()] == list(tax.kinds)
    assert [s.key for s in palette.body_classes()] == [f"part-{c}" for c in tax.subclasses("BodyPart")]
    colours = [s.colour for s in (*palette.kinds(), *palette.body_classes())]
    assert len(set(colours)) == len(colours)
    assert palette.body_swatch("Arm").label == "arm" and palette.body_swatch("Camera").colour == palette.OTHER
    assert palette.kind_colour("sensor") != palette.kind_colour("end_effector") != palette.OTHER
    assert all(f".dot.{s.key} {{ background: {s.colour}; }}" in palette.css() for s in palette.body_classes())


def test_nothing_else_names_a_kind_or_its_colour():
    names = [*(s.key for s in palette.kinds()), *(s.colour for s in (*palette.kinds(), *palette.body_classes()))]
    files = [KB_SERVER / "tree_svg.py", *(KB_SERVER / "templates").iterdir(), *(KB_SERVER / "static").iterdir()]
    found = [(f.name, n) for f in files for n in names if re.search(rf"(?<![\w-]){re.escape(n)}(?![\w-])", f.read_text(), re.I)]
    assert found == []
