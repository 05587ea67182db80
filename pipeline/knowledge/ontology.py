"""The vocabulary: the core ontology and its shapes, parsed once, as everything the code knows of the schema.

`ontologies/urdfkb.owl` and `ontologies/shapes.ttl` are the single source of truth; `Vocabulary` is a
read-only view of them (classes, labels, definitions, examples, answer phrases, the component kinds
and their sub-part branches, sub-parts excluded or required, joint-type and simulator alignments,
the body's classes, where a component may sit), and holds the two parsed graphs that export and SHACL validation reuse.
"""
from __future__ import annotations

import functools
import hashlib
import importlib.resources
import pathlib
from dataclasses import dataclass
from typing import Iterable

import rdflib
from rdflib.namespace import OWL, RDF, RDFS, SH, SKOS

from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.namespaces import CORE, CORE_IRI, CORE_ONTOLOGY_IRI
from urdfkb.pipeline.knowledge.ontology_axioms import count_range, local_name, needed_parts, placement_of, restricted_parts, stated_value

_LOADED_MARK = CORE_IRI + "ontologyVersion"
FINGER_CHAIN_ROLES = ("link", "tip", "carrier")  # the values core:fingerChainRole may take
# The body's class, and the two of its direct subclasses the body pass gives a role (the base the other
# base chains join around, the wheels it carries): the only body-part names the code writes out.
BODY_PART, MOBILE_BASE, WHEEL = "BodyPart", "MobileBase", "Wheel"


def core_path() -> pathlib.Path:
    """Path of the packaged core ontology (RDF/XML)."""
    return _packaged("urdfkb.owl")


def shapes_path() -> pathlib.Path:
    """Path of the packaged SHACL shapes (Turtle)."""
    return _packaged("shapes.ttl")


def _packaged(name: str) -> pathlib.Path:
    return pathlib.Path(str(importlib.resources.files("urdfkb.ontologies").joinpath(name)))


def load_core(world: rdf.World, vocab: "Vocabulary | None" = None) -> rdf.Ontology:
    """Load the core (of `vocab`, the packaged one by default) into `world`, offline; no-op if this
    version is there.

    The loaded version is recorded on the core ontology in the world, so a persistent
    (SQLite) world holding an older core is reloaded in place.
    """
    vocab = vocab or vocabulary()
    onto = world.get_ontology(CORE_ONTOLOGY_IRI)
    if rdf.ontology_value(onto, _LOADED_MARK) == vocab.version:
        return onto
    with vocab.path.open("rb") as f:
        onto.load(fileobj=f, reload=onto.loaded)
    rdf.set_ontology_value(onto, _LOADED_MARK, vocab.version)
    return onto


@dataclass(frozen=True)
class Kind:
    """A kind of component the pipeline abstracts: a subclass of Component carrying core:componentKind."""

    name: str        # core:componentKind: how abstractions and truth files name the kind
    cls: str         # the class itself, under Component
    subparts: str    # its sub-components' branch under Subpart (`cls ⊑ ∀hasComponent.subparts`)
    noun: str        # core:promptNoun: how questions name such a device in running text
    mount_rule: str  # core:mountRule: how the attachment question says which ancestor is its mount


class _OrderedGraph(rdflib.Graph):
    """An rdflib graph that remembers the order in which its typed nodes were first declared (the
    RDF/XML parser adds each node's rdf:type triple as it meets the node)."""

    def __init__(self) -> None:
        super().__init__()
        self.declared: dict[rdflib.term.Node, None] = {}

    def add(self, triple):
        if triple[1] == RDF.type and triple[2] == OWL.Class:
            self.declared.setdefault(triple[0])
        return super().add(triple)


class Vocabulary:
    """The core's named classes in the file's (spec's) order, what the core and its shapes say about
    them, and the two parsed graphs (`graph`, `shapes`)."""

    def __init__(self, path: pathlib.Path, shapes: pathlib.Path):
        self.path, self.shapes_path = pathlib.Path(path), pathlib.Path(shapes)
        core_bytes, shapes_bytes = self.path.read_bytes(), self.shapes_path.read_bytes()
        self.version = hashlib.sha256(core_bytes).hexdigest()[:16]
        # what an abstraction depends on: both files
        self.fingerprint = hashlib.sha256(core_bytes + b"\0" + shapes_bytes).hexdigest()[:16]
        graph = _OrderedGraph()
        graph.parse(data=core_bytes, format="xml", publicID=self.path.as_uri())
        self.graph: rdflib.Graph = graph
        self.shapes = rdflib.Graph().parse(data=shapes_bytes, format="turtle")
        self._order = {n: i for i, n in enumerate(filter(None, map(local_name, graph.declared)))}
        self._parents: dict[str, tuple[str, ...]] = {}
        self._children: dict[str, list[str]] = {n: [] for n in self._order}
        self._label: dict[str, str] = {}
        self._answer: dict[str, str] = {}
        self._comment: dict[str, str] = {}
        self._example: dict[str, str] = {}
        self._excluded: dict[str, set[str]] = {}
        self._needed: dict[str, list[frozenset[str]]] = {}  # class → for each ∃hasComponent.(X ⊔ …): {X, …}
        self._declared_by: dict[str, set[str]] = {}  # SDF sensor type → classes aligned to it
        self._pixels: dict[str, set[str]] = {}  # class → the SDF pixel formats of its images (core:pixelFormat)
        self._joint_class: dict[str, str] = {}  # URDF joint type → its class
        self._chain_class: dict[str, str] = {}  # a finger chain's drive motion → its class
        self._roles: dict[str, str] = {}  # class → its core:fingerChainRole
        self._units: set[str] = set()  # classes marked core:numberedUnits
        self._built_in: set[str] = set()  # classes marked core:builtIn
        self._frame_only: set[str] = set()  # classes marked core:frameOnly
        self._part_question: dict[str, str] = {}  # required part class → core:partQuestion
        self._views: dict[str, tuple[float, float]] = {}  # camera class → the viewpoint counts it allows
        self._elements: dict[str, tuple[float, float]] = {}  # sensor class → the sensing-frame counts it allows
        self._fields: dict[str, tuple[float, float]] = {}  # ray sensor class → the declared spans (rad) it allows
        self._radiation: dict[str, str] = {}  # ranging sensor class → what it emits (core:rangingRadiation value)
        self._vertical: dict[str, str] = {}  # body-part class → its core:turnsAboutVertical value, where stated
        self._sliding: dict[str, str] = {}  # body-part class → its core:slidesOnly value, where stated
        self._rank: dict[str, float] = {}  # class → core:optionRank
        self._other: dict[str, tuple[str, str]] = {}  # class → (core:otherAnswer, core:otherComment)
        self._placements: dict[str, str] = {}  # class → where it may sit (its ∀isLocatedOn restriction, as text)
        for name in self._order:
            node = CORE[name]
            parents = sorted(filter(None, map(local_name, graph.objects(node, RDFS.subClassOf))),
                             key=self._order.__getitem__)
            self._parents[name] = tuple(parents)
            for p in parents:
                self._children[p].append(name)
            self._label[name] = str(graph.value(node, RDFS.label) or name)
            self._answer[name] = str(graph.value(node, SKOS.altLabel) or self._label[name])
            self._comment[name] = str(graph.value(node, RDFS.comment) or "")
            self._example[name] = str(graph.value(node, SKOS.example) or "")
            self._excluded[name] = restricted_parts(graph, node, complement=True)
            self._needed[name] = needed_parts(graph, node)
            if (views := count_range(graph, node, CORE.viewpointCount)) is not None:
                self._views[name] = views
            if (elements := count_range(graph, node, CORE.elementCount)) is not None:
                self._elements[name] = elements
            if (field := count_range(graph, node, CORE.horizontalFieldOfViewRadians)) is not None:
                self._fields[name] = field
            if (radiation := stated_value(graph, node, CORE.rangingRadiation)) is not None:
                self._radiation[name] = radiation
            if (vertical := stated_value(graph, node, CORE.turnsAboutVertical)) is not None:
                self._vertical[name] = vertical.strip().lower()
            if (sliding := stated_value(graph, node, CORE.slidesOnly)) is not None:
                self._sliding[name] = sliding.strip().lower()
            if (placement := placement_of(graph, node)) is not None:
                self._placements[name] = f"{name} ⊑ ∀isLocatedOn.{placement}"
            for sim_type in graph.objects(node, CORE.simulatorSensorType):
                self._declared_by.setdefault(str(sim_type).strip().lower(), set()).add(name)
            for pixels in graph.objects(node, CORE.pixelFormat):
                self._pixels.setdefault(name, set()).add(str(pixels).strip().lower())
            for joint_type in graph.objects(node, CORE.urdfJointType):
                self._joint_class[str(joint_type)] = name
            for motion in graph.objects(node, CORE.fingerDrive):
                self._chain_class[str(motion)] = name
            if (role := graph.value(node, CORE.fingerChainRole)) is not None:
                if str(role) not in FINGER_CHAIN_ROLES:
                    raise OntologyError(f"{name}: core:fingerChainRole {str(role)!r} is none of {FINGER_CHAIN_ROLES}")
                self._roles[name] = str(role)
            if (rank := graph.value(node, CORE.optionRank)) is not None:
                self._rank[name] = float(str(rank))
            if (other := graph.value(node, CORE.otherAnswer)) is not None:
                self._other[name] = (str(other), str(graph.value(node, CORE.otherComment) or ""))
            if (question := graph.value(node, CORE.partQuestion)) is not None:
                self._part_question[name] = str(question)
            if str(graph.value(node, CORE.numberedUnits)).strip().lower() in ("true", "1"):
                self._units.add(name)
            if str(graph.value(node, CORE.builtIn)).strip().lower() in ("true", "1"):
                self._built_in.add(name)
            if str(graph.value(node, CORE.frameOnly)).strip().lower() in ("true", "1"):
                self._frame_only.add(name)
        for kids in self._children.values():
            kids.sort(key=self._order.__getitem__)
        self.kinds = self._read_kinds()
        self._required = self._read_required_parts()
        self.body_part, self.mobile_base, self.wheel = self._body_roles()

    def _read_kinds(self) -> dict[str, Kind]:
        kinds = {}
        for name in self._order:
            node = CORE[name]
            kind = self.graph.value(node, CORE.componentKind)
            if kind is None:
                continue
            branches = restricted_parts(self.graph, node, complement=False)
            noun, rule = self.graph.value(node, CORE.promptNoun), self.graph.value(node, CORE.mountRule)
            if len(branches) != 1 or noun is None or rule is None:
                raise OntologyError(f"{name} carries core:componentKind but not one ∀hasComponent branch, "
                                    "a core:promptNoun and a core:mountRule")
            kinds[str(kind)] = Kind(str(kind), name, branches.pop(), str(noun), str(rule))
        self.component = self._shared_parent([k.cls for k in kinds.values()], "the component kinds")
        self.subpart = self._shared_parent([k.subparts for k in kinds.values()], "the kinds' sub-part branches")
        return kinds

    def _shared_parent(self, classes: list[str], what: str) -> str:
        parents = {p for c in classes for p in self.parents(c)}
        if len(parents) != 1:
            raise OntologyError(f"{what} ({', '.join(classes)}) do not share one superclass")
        return parents.pop()

    def _body_roles(self) -> tuple[str, str, str]:
        """BODY_PART, MOBILE_BASE and WHEEL, once the file is seen to declare the two directly below the first."""
        for name in (MOBILE_BASE, WHEEL):
            if name not in self or BODY_PART not in self.parents(name):
                raise OntologyError(f"the core declares no class {name} directly below {BODY_PART}")
        return BODY_PART, MOBILE_BASE, WHEEL

    @property
    def body_classes(self) -> tuple[str, ...]:
        """The direct subclasses of the body's class (what a body part is), in the file's order."""
        return self.subclasses(self.body_part)

    def offered(self, classes: Iterable[str]) -> tuple[str, ...]:
        """`classes` in the order they are offered to the model: by core:optionRank, the unranked after, in
        the file's order."""
        return tuple(sorted(classes, key=lambda c: (self._rank.get(c, float("inf")), self._order[c])))

    def _read_required_parts(self) -> dict[str, str]:
        """Class → the sub-part class a shape requires at least one of (sh:qualifiedValueShape on hasComponent)."""
        required = {}
        for shape in self.shapes.subjects(RDF.type, SH.NodeShape):
            targets = [t for t in map(local_name, self.shapes.objects(shape, SH.targetClass)) if t]
            for prop in self.shapes.objects(shape, SH.property):
                part = self.shapes.value(self.shapes.value(prop, SH.qualifiedValueShape), SH["class"])
                least = self.shapes.value(prop, SH.qualifiedMinCount)
                if (self.shapes.value(prop, SH.path) != CORE.hasComponent or (local := local_name(part)) is None
                        or not least):
                    continue
                for target in targets:
                    if target in required:
                        raise OntologyError(f"the shapes require two kinds of part of a {target}")
                    required[target] = local
        return required

    def _check(self, name: str) -> str:
        if name not in self._order:
            raise OntologyError(f"unknown ontology class {name!r}")
        return name

    def __contains__(self, name: object) -> bool:
        return name in self._order

    def subclasses(self, name: str) -> tuple[str, ...]:
        """Direct named subclasses, in the file's order."""
        return tuple(self._children[self._check(name)])

    def subclasses_below(self, name: str) -> tuple[str, ...]:
        """Every named class under `name`, in the file's order."""
        return tuple(c for c in self._order if c != name and name in self.ancestors(c))

    def branch(self, name: str) -> frozenset[str]:
        """`name` and every class under it."""
        return frozenset((name, *self.subclasses_below(name)))

    def parents(self, name: str) -> tuple[str, ...]:
        """Direct named core superclasses (alignment classes such as sosa:Sensor excluded)."""
        return self._parents[self._check(name)]

    def ancestors(self, name: str) -> tuple[str, ...]:
        """All core superclasses, nearest first, without `name` itself."""
        seen: list[str] = []
        frontier = list(self.parents(name))
        while frontier:
            current = frontier.pop(0)
            if current not in seen:
                seen.append(current)
                frontier.extend(self._parents[current])
        return tuple(seen)

    def is_a(self, name: str, ancestor: str) -> bool:
        """True if `name` is `ancestor` or one of its subclasses."""
        return name == self._check(ancestor) or ancestor in self.ancestors(name)

    def is_leaf(self, name: str) -> bool:
        return not self.subclasses(name)

    def label(self, name: str) -> str:
        return self._label[self._check(name)]

    def answer(self, name: str) -> str:
        """The phrase offered to the model for this class: skos:altLabel where given, else the label."""
        return self._answer[self._check(name)]

    def comment(self, name: str) -> str:
        """The class definition shown to the model when it chooses among siblings."""
        return self._comment[self._check(name)]

    def example(self, name: str) -> str:
        """An invented link name typical of the class (skos:example), or ''."""
        return self._example[self._check(name)]

    def kind_of(self, name: str) -> str | None:
        """The kind (core:componentKind) whose class `name` falls under, or None."""
        return next((k for k, kind in self.kinds.items() if name in self and self.is_a(name, kind.cls)), None)

    def excluded_parts(self, name: str) -> frozenset[str]:
        """Classes a `name` device may not have as sub-components (∀hasComponent.¬X on it or an
        ancestor), with their subclasses."""
        direct = set().union(*(self._excluded[c] for c in (self._check(name), *self.ancestors(name))))
        return frozenset(c for c in self._order if any(self.is_a(c, x) for x in direct))

    def unfit(self, parts: frozenset[str], below: str) -> frozenset[str]:
        """Classes under `below` that a device whose sub-parts are all of `parts` (and nothing else) cannot be:
        one of the parts is excluded from them (∀hasComponent.¬X), or they need a part none of `parts` is
        (∃hasComponent.X on them or a class above them: an RGB-D camera has a colour frame and a depth or
        infrared one)."""
        def fits(name: str) -> bool:
            if parts & self.excluded_parts(name):
                return False
            needs = [n for c in (name, *self.ancestors(name)) for n in self._needed.get(c, [])]
            return all(any(self.is_a(p, x) for p in parts for x in need) for need in needs)
        return frozenset(c for c in self.subclasses_below(below) if not fits(c))

    def required_part(self, name: str) -> str | None:
        """The sub-part class a `name` device must have one of (a qualified shape on it or an
        ancestor, ontologies/shapes.ttl), or None."""
        holder = self.requiring_class(name)
        return self._required[holder] if holder else None

    def requiring_class(self, name: str) -> str | None:
        """The class (`name` or its nearest ancestor) whose shape requires a part of a `name` device, or None."""
        return next((c for c in (self._check(name), *self.ancestors(name)) if c in self._required), None)

    def domain(self, prop: str) -> str:
        """The named core class a core property applies to (its rdfs:domain): what population writes it on."""
        return self._bound(prop, RDFS.domain)

    def range(self, prop: str) -> str:
        """The named core class a core object property's values fall in (its rdfs:range)."""
        return self._bound(prop, RDFS.range)

    def _bound(self, prop: str, which: rdflib.URIRef) -> str:
        name = local_name(self.graph.value(CORE[prop], which))
        if name is None or name not in self:
            raise OntologyError(f"core property {prop!r} has no named core class as its rdfs:{which.fragment}")
        return name

    def part_question(self, part: str) -> str | None:
        """The question refining a link taken as a required `part` (core:partQuestion), or None."""
        return self._part_question.get(self._check(part))

    def other(self, name: str) -> tuple[str, str] | None:
        """(answer, definition) offered beside `name`'s subclasses meaning `name` itself (core:otherAnswer), or None."""
        return self._other.get(self._check(name))

    def has_numbered_units(self, name: str) -> bool:
        """A `name` device is made of numbered units read as one (core:numberedUnits on it or an ancestor)."""
        return any(c in self._units for c in (self._check(name), *self.ancestors(name)))

    def built_in(self, name: str) -> bool:
        """Devices of other kinds often carry a `name` inside (core:builtIn on it or an ancestor: an IMU)."""
        return any(c in self._built_in for c in (self._check(name), *self.ancestors(name)))

    def frame_only(self) -> frozenset[str]:
        """Classes marked core:frameOnly, with their subclasses: bare frames only, no drawn link."""
        return frozenset(c for c in self._order if any(self.is_a(c, f) for f in self._frame_only))

    def finger_chain_role(self, role: str) -> frozenset[str]:
        """Classes carrying core:fingerChainRole `role`, with their subclasses."""
        return frozenset(c for c in self._order if any(self.is_a(c, r) for r, v in self._roles.items() if v == role))

    def joint_class(self, urdf_type: str) -> str:
        """The class of joints of this URDF type (core:urdfJointType)."""
        try:
            return self._joint_class[urdf_type]
        except KeyError:
            raise OntologyError(f"no class of the core ontology is aligned to URDF joint type {urdf_type!r}") from None

    def finger_chain_class(self, motion: str) -> str:
        """The class of finger chains whose drive moves them so (core:fingerDrive)."""
        try:
            return self._chain_class[motion]
        except KeyError:
            raise OntologyError(f"no class of the core ontology is aligned to finger drive {motion!r}") from None

    def declared_classes(self, sim_types: Iterable[str]) -> frozenset[str]:
        """Classes the ontology aligns to any of these simulator (SDF) sensor types (core:simulatorSensorType)."""
        return frozenset(c for t in sim_types for c in self._declared_by.get(t.strip().lower(), ()))

    def unformatted(self, formats: Iterable[str], below: str) -> frozenset[str]:
        """Classes under `below` whose images none of these SDF pixel formats is (core:pixelFormat: a frame whose
        camera states L8 gives no colour image); none where no format is stated."""
        stated = {f.strip().lower() for f in formats}
        if not stated:
            return frozenset()
        return frozenset(c for c in self.subclasses_below(below) if c in self._pixels and not stated & self._pixels[c])

    def unseen(self, count: int | None, below: str) -> frozenset[str]:
        """Classes under `below` that a device whose optical frames see from `count` places cannot be
        (core:viewpointCount restrictions on them or on a class above them: a stereo camera sees from two);
        none where the count is unknown (None: a camera written as one body)."""
        return frozenset() if count is None else self._outside(self._views, count, below)

    def miscounted(self, count: int, below: str) -> frozenset[str]:
        """Classes under `below` that a device written with `count` sensing frames cannot be (core:elementCount
        restrictions on them or on a class above them: a tactile sensor is one pad, several are an array)."""
        return self._outside(self._elements, count, below)

    def too_narrow(self, span: float, below: str) -> frozenset[str]:
        """Classes under `below` that a sensor declared to sweep `span` radians cannot be
        (core:horizontalFieldOfViewRadians restrictions: a lidar sweeps a wide field, a sonar a cone)."""
        return self._outside(self._fields, span, below)

    def emitting_otherwise(self, radiation: str, below: str) -> frozenset[str]:
        """Classes under `below` that a ranging sensor declared to emit `radiation` cannot be (core:rangingRadiation
        values stated on them or on a class above them: a sonar emits ultrasound, a lidar infrared light)."""
        return frozenset(c for c in self.subclasses_below(below)
                         if any(self._radiation.get(a, radiation) != radiation for a in (c, *self.ancestors(c))))

    def turning_otherwise(self, vertical: bool, among: Iterable[str]) -> frozenset[str]:
        """Those of the body-part classes `among` that a candidate whose joints do (or do not) all turn about the
        vertical cannot be (core:turnsAboutVertical values stated on them or on a class above them: a wheel rolls
        about a level axis)."""
        return self._stated_otherwise(self._vertical, vertical, among)

    def sliding_otherwise(self, sliding: bool, among: Iterable[str]) -> frozenset[str]:
        """Those of the body-part classes `among` that a candidate whose joints do (or do not) all slide cannot be
        (core:slidesOnly values stated on them or on a class above them: a head pans and tilts, a wheel rolls)."""
        return self._stated_otherwise(self._sliding, sliding, among)

    def _stated_otherwise(self, stated: dict[str, str], value: bool, among: Iterable[str]) -> frozenset[str]:
        said = "true" if value else "false"
        return frozenset(c for c in among
                         if any(stated.get(a, said) not in (said, "1" if value else "0")
                                for a in (c, *self.ancestors(c))))

    def _outside(self, ranges: dict[str, tuple[float, float]], count: float, below: str) -> frozenset[str]:
        def allows(name: str) -> bool:
            return all(low <= count <= high for c in (name, *self.ancestors(name))
                       for low, high in [ranges.get(c, (0, float("inf")))])
        return frozenset(c for c in self.subclasses_below(below) if not allows(c))

    def placement(self, name: str) -> str | None:
        """Where a `name` component may sit, as the restriction on it or its nearest ancestor that says so
        ("Bumper ⊑ ∀isLocatedOn.(MobileBase ⊔ Leg)"), or None: what the body pass's placement step has a
        reasoner check against the body part the component is located on."""
        return next((self._placements[c] for c in (self._check(name), *self.ancestors(name)) if c in self._placements),
                    None)

    def disagreeing(self, declared: frozenset[str], below: str) -> frozenset[str]:
        """Classes under `below` that agree with none of `declared` (neither above nor below one of them):
        what a declaration rules out. Empty when nothing is declared or nothing declared lies under `below`."""
        declared = frozenset(d for d in declared if self.is_a(d, below))
        if not declared:
            return frozenset()
        return frozenset(c for c in self.subclasses_below(below)
                         if not any(self.is_a(c, d) or self.is_a(d, c) for d in declared))


@functools.cache
def vocabulary(path: pathlib.Path | None = None, shapes: pathlib.Path | None = None) -> Vocabulary:
    """The vocabulary of a core and its shapes (the packaged ones by default), built once per process."""
    return Vocabulary(path or core_path(), shapes or shapes_path())
