"""The colours of the review pages, in one place, keyed by what the ontology names.

A component kind (core:componentKind, in the ontology's order) takes the next of KIND_COLOURS; a
body-part class the next of BODY_COLOURS in the order of BodyPart's direct subclasses, and a finer
class its ancestor's. The tree (tree_svg), the legends (templates) and the stylesheet rules for the
dots (`css()`, which base.html inlines) all read them here, so nothing else names a kind or a colour.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from urdfkb.pipeline.knowledge.ontology import vocabulary

KIND_COLOURS = ("#1f77b4", "#d95f02", "#7570b3", "#e7298a")
BODY_COLOURS = ("#66a61e", "#999933", "#8c6bb1", "#1b9e77", "#e7298a", "#a6761d", "#666666")
OTHER = "#777777"  # a class of no kind the palette knows


@dataclass(frozen=True)
class Swatch:
    """One legend entry: the CSS class the dots use, what the legend calls it, its colour."""

    key: str
    label: str
    colour: str


@cache
def kinds() -> tuple[Swatch, ...]:
    """Each component kind's swatch, keyed by the kind's name (`sensor`)."""
    vocab = vocabulary()
    return tuple(Swatch(name, vocab.label(kind.cls), KIND_COLOURS[i % len(KIND_COLOURS)])
                 for i, (name, kind) in enumerate(vocab.kinds.items()))


@cache
def body_classes() -> tuple[Swatch, ...]:
    """Each direct subclass of the body's class's swatch (Vocabulary.body_classes), keyed `part-<Class>`."""
    vocab = vocabulary()
    return tuple(Swatch(f"part-{cls}", vocab.label(cls), BODY_COLOURS[i % len(BODY_COLOURS)])
                 for i, cls in enumerate(vocab.body_classes))


def kind_colour(kind: str) -> str:
    return next((s.colour for s in kinds() if s.key == kind), OTHER)


def body_swatch(cls: str) -> Swatch:
    """The swatch of the direct BodyPart subclass `cls` is (or falls under)."""
    vocab = vocabulary()
    return next((s for s in body_classes() if cls in vocab and vocab.is_a(cls, s.key.removeprefix("part-"))),
                Swatch("part-other", cls, OTHER))


@cache
def css() -> str:
    """The dots' stylesheet rules, one per swatch."""
    return "\n".join(f".dot.{s.key} {{ background: {s.colour}; }}" for s in (*kinds(), *body_classes()))
