"""Device and sub-part classes: each sub-chain's class (pre-classification), a device's class from its
members' (post-classification), numbered units, and each member link's sub-part class
(stages.classification, stages.subparts)."""
from __future__ import annotations

import itertools
from collections.abc import Iterable

from urdfkb.pipeline.abstraction.catalogue import Product
from urdfkb.pipeline.knowledge.ontology import Vocabulary
from urdfkb.pipeline.reading.evidence import LinkEvidence, named
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.prompts import product_text
from urdfkb.pipeline.abstraction.stages.attachment import SubChain
from urdfkb.pipeline.abstraction.stages.classification import Subject, descend
from urdfkb.pipeline.abstraction.stages.grouping import VISION, Group
from urdfkb.pipeline.abstraction.stages.identification import device_product, named_product
from urdfkb.pipeline.abstraction.stages.sensor_check import MAJORITY
from urdfkb.pipeline.abstraction.stages.subparts import image_kinds, required_parts_first, type_subparts
from urdfkb.pipeline.abstraction.stages.verification import indexed_units
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.devices import category
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.abstraction.frames import is_optical, viewpoints
from urdfkb.pipeline.reading.tree import KinematicTree

MAX_FACTS = 3  # links of a chain shown with their facts
_NO_FACTS = LinkEvidence()


def chain_subject(ctx: Context, tree: KinematicTree, chain: SubChain, cls: str) -> Subject:
    """A sub-chain to pre-classify below `cls`: its links, their facts, what a declaration rules out.

    Declared simulator sensors speak here only by narrowing the options: shown as words (type, plugin,
    ray counts) they pull a small model off the right class (a 'depth' declaration or a 'depth_camera'
    plugin towards depth camera for RGB-D and monocular cameras, ray counts towards lidar for sonars),
    while identification gains from them."""
    key = f"pre:{chain.leaf}"
    named_as = named_product(tree, list(reversed(chain.links)))
    ruled_out = (_ruled_out(ctx, tree, chain.links, cls, key, _classes_of(ctx.vocab, named_as))
                 | _off_product(ctx.vocab, named_as, cls))
    with_facts = [link for link in reversed(chain.links) if tree.evidence.get(link, _NO_FACTS).text()][:MAX_FACTS]
    shown = [named(tree.evidence, link) if link in with_facts else link for link in chain.links]
    between = f"\nBetween it and its mount: {', '.join(shown[:-1])}" if len(shown) > 1 else ""
    product = product_text(ctx.vocab, named_as, cls)
    return Subject(key, "The link below belongs to a {concept}.", f"Link: {shown[-1]}{between}{product}", ruled_out)


def _off_product(vocab: Vocabulary, product: Product | None, start: str) -> frozenset[str]:
    """The classes a catalogue product rules out of a descent from `start`: those under its own class (the
    catalogue names a product's most specific class: a single-beam time-of-flight ranger is no lidar and no sonar),
    and, within each branch of `start` its class lies in, those beside it (a Doppler velocity log, a sonar, is no
    lidar). The branch itself stays the model's to choose (an inertial frame inside a named camera), and so does
    staying above the product's class."""
    if product is None or product.cls not in vocab or not vocab.is_a(product.cls, start):
        return frozenset()
    cls = product.cls
    branches = [b for b in vocab.subclasses(start) if vocab.is_a(cls, b)]
    beside = {c for b in branches for c in vocab.subclasses_below(b) if not vocab.is_a(cls, c) and not vocab.is_a(c, cls)}
    return frozenset(vocab.subclasses_below(cls)) | beside


RGBD = "rgbd_camera"  # SDF's sensor type of a camera giving colour and depth


def _ruled_out(ctx: Context, tree: KinematicTree, links: Iterable[str], below: str, key: str,
               named: frozenset[str] = frozenset()) -> frozenset[str]:
    """Classes under `below` that the simulator sensors declared on `links` rule out: by their type (the
    ontology's core:simulatorSensorType alignment; where one link declares a depth sensor and a sensor giving colour,
    one device gives both, and every declaration on the links an RGB-D camera fits is SDF's `rgbd_camera`: the
    colour, depth and infrared imagers of that device), except the `named` classes of the catalogue product the links
    name (a simulator has no type for many products and stands one in: an imaging sonar swept as a GPU ray scan),
    and by the span a ray sensor sweeps
    (core:horizontalFieldOfViewRadians restrictions: a 10-degree beam is no lidar) and by what a ranging sensor
    emits (core:rangingRadiation values: an infrared beam is no sonar); each narrowing is counted and logged."""
    vocab = ctx.vocab
    links = list(links)
    sensors = [s for link in links for s in tree.evidence.get(link, _NO_FACTS).sensors]
    types = {s.sdf_type for s in sensors} | _plugin_types(vocab, tree, links)
    if any(d.type == "depth" and any(c.colour and c.reference == d.reference for c in sensors) for d in sensors):
        rgbd = vocab.declared_classes([RGBD])
        types = {RGBD if any(vocab.is_a(r, c) for r in rgbd for c in vocab.declared_classes([t])) else t for t in types}
    declared = vocab.declared_classes(types)
    ruled_out = vocab.disagreeing(declared, below) - named
    spans = [s.fov for s in sensors if s.fov is not None and s.ranging]  # ray sensors' sweeps
    narrow = vocab.too_narrow(max(spans), below) - ruled_out if spans else frozenset()
    radiations = {s.radiation for s in sensors if s.radiation is not None}
    radiation = radiations.pop() if len(radiations) == 1 else None
    emitting = vocab.emitting_otherwise(radiation, below) - ruled_out - narrow if radiation else frozenset()
    if ruled_out or narrow or emitting:
        ctx.tally.declared += 1
        ctx.log(f"{key}: declared {sorted(types)} -> {sorted(declared)}"
                + (f"; sweeping {max(spans):.2f} rad, not {sorted(narrow)}" if narrow else "")
                + (f"; emitting {radiation}, not {sorted(emitting)}" if emitting else ""))
    return ruled_out | narrow | emitting


def _plugin_types(vocab: Vocabulary, tree: KinematicTree, links: list[str]) -> set[str]:
    """The simulator sensor types that the plugins naming `links` outside any sensor declaration carry as words of
    their library's name: a sensor a simulator gives by a plugin alone, with no <sensor> (RotorS'
    rotors_gazebo_imu_plugin, Gazebo's gazebo_ros_imu naming their IMU link), is declared as a sensor of that type is."""
    found = set()
    for stem in (p for link in links for p in tree.evidence.get(link, _NO_FACTS).plugins):
        words = stem.lower().replace("-", "_").split("_")
        found |= {run for i in range(len(words)) for j in range(i + 1, len(words) + 1)
                  if vocab.declared_classes([run := "_".join(words[i:j])])}
    return found


@step("pre-classification", needs=("chains",), makes=("pre",))
def pre_classification(ctx: Context, found: Findings) -> None:
    """Each sub-chain's class below the pass's kind; alike leaves (structure.alike_leaves) whose declarations
    rule out the same classes, offered the same answers, are asked once, the first standing for all."""
    kind = ctx.device_kind
    subjects = {c.leaf: chain_subject(ctx, ctx.tree, c, kind.cls) for c in found.chains}
    sets = alike_sets(ctx.tree, list(subjects), lambda a, b: subjects[a].exclude == subjects[b].exclude)
    typed = descend(ctx.oracle, ctx.vocab, kind.cls, [subjects[leaves[0]] for leaves in sets],
                    "pre-classification", ctx.progress)
    by_leaf = {leaf: t for leaves, t in zip(sets, typed) for leaf in leaves}
    found.pre = {c.leaf: by_leaf[c.leaf] for c in found.chains}


@step("built-in frames", needs=("chains", "pre"), makes=("pre",))
def built_in_frames(ctx: Context, found: Findings) -> None:
    """A frame of a kind that devices of other kinds carry inside (Vocabulary.built_in: a lidar's or a
    camera's own IMU), alone below a housing link of its chain, is a part of the device that housing is:
    the housing is classified as a link of its own, and a sensor kind that is not built in, reached with
    the majority of the votes, becomes the chain's pre-class (the ontology spec: a device's own inertial
    frames belong to it; a bracket the model cannot place leaves the frame an IMU of its own)."""
    kind, vocab, tree, pre = ctx.device_kind, ctx.vocab, ctx.tree, found.pre
    hosted = [c for c in found.chains if len(c.links) > 1 and vocab.built_in(pre[c.leaf].cls)
              and [link for link in tree.descendants(c.links[-2]) if tree.is_leaf(link)] == [c.leaf]]
    if not hosted:
        return
    housings = [SubChain(c.links[-2], c.root, c.links[:-1]) for c in hosted]
    typed = descend(ctx.oracle, vocab, kind.cls, [chain_subject(ctx, tree, h, kind.cls) for h in housings],
                    "pre-classification", ctx.progress)
    for c, h, t in zip(hosted, housings, typed):
        if t.cls != kind.cls and not vocab.built_in(t.cls) and t.confidence > MAJORITY:
            ctx.log(f"pre:{c.leaf}: the built-in {vocab.label(pre[c.leaf].cls)} of {h.leaf}, a {t.cls}")
            pre[c.leaf] = t


@step("post-classification", needs=("groups", "pre"), makes=("post", "parts"))
def post_classification(ctx: Context, found: Findings) -> None:
    """Multi-chain groups descend again from what their members share; a lone chain keeps its class,
    unless where its frames see from rules that class out, or, for a lone optical frame, the kind of image it
    gives (below).

    The descent starts at the deepest class common to the members' pre-classes (a camera's: its imaging
    frames', not its own inertial or model frames'), or one level
    above it when that is a leaf class, so that siblings stay open (several sonar frames may
    still be one sonar, several microphones an array, colour and depth frames an RGB-D camera).
    Where a device's optical frames see from (frames.viewpoints; unknown for a camera written as one body but
    the eye of a pair) rules classes out by the ontology's core:viewpointCount definitions (a monocular camera sees from one
    place, a stereo camera from two), they are not offered; a lone chain's pre-class so ruled out descends
    again from its parent.
    Nor are the classes the number of its sensing frames rules out (core:elementCount: a tactile sensor is
    one pad, a microphone one capsule; several read as one device are an array).
    """
    top, vocab, tree, pre = ctx.device_kind.cls, ctx.vocab, ctx.tree, found.pre
    typed = {id(g): pre[g.leaves[0]] for g in found.groups}
    by_start: dict[str, list[Group]] = {}
    imaging = {id(g): _imaging(ctx, found, g) for g in found.groups}
    camera = vocab.domain("viewpointCount")
    cameras = [leaf for g in found.groups for leaf in g.leaves if vocab.is_a(pre[leaf].cls, camera)]
    views = {id(g): viewpoints(tree, g.leaves, cameras) for g in found.groups}
    counted_out = {id(g): vocab.unseen(views[id(g)], top) | vocab.miscounted(len(g.chains), top)
                   for g in found.groups}  # by where its frames see from, and by how many there are
    imaged_out = {id(g): _images_out(ctx, g, camera, top) if len(g.chains) == 1 else frozenset()
                  for g in found.groups}  # by the images declared on a lone chain
    ruled_out = {i: counted_out[i] | imaged_out[i] for i in counted_out}
    lone_frames = [g for g in found.groups if len(g.chains) == 1 and pre[g.leaves[0]].cls not in ruled_out[id(g)]
                   and vocab.is_a(pre[g.leaves[0]].cls, camera) and is_optical(tree, g.leaves[0])]
    unfit = _frames_first(ctx, found, lone_frames, camera, imaging, classified=True)  # one image's kind
    for g in found.groups:
        if len(g.chains) > 1:
            by_start.setdefault(_shared_class(ctx, {pre[leaf].cls for leaf in imaging[id(g)]}, top), []).append(g)
        elif (cls := pre[g.leaves[0]].cls) in ruled_out[id(g)] | unfit.get(id(g), frozenset()):
            if cls in counted_out[id(g)]:
                ctx.log(f"post:{g.leaves[0]}: its frames see from {views[id(g)]} place(s), so it is no {cls}")
            if cls in imaged_out[id(g)]:
                ctx.log(f"post:{g.leaves[0]}: the images declared on it fit no {cls}")
            by_start.setdefault(vocab.parents(cls)[0], []).append(g)
    for start, members in by_start.items():
        unfit |= _frames_first(ctx, found, [g for g in members if len(g.chains) > 1], start, imaging)
        results = descend(ctx.oracle, vocab, start, [
            Subject(f"post:{g.leaves[0]}", "The frames below form one {concept} device.",
                    "Frames: " + "; ".join(f"{leaf} ({vocab.label(pre[leaf].cls)})" for leaf in g.leaves),
                    _declared_first(ctx, g, start, ruled_out[id(g)], unfit.get(id(g), frozenset())))
            for g in members
        ], "post-classification", ctx.progress)
        typed.update({id(g): t for g, t in zip(members, results)})
    found.post = [typed[id(g)] for g in found.groups]


def _images_out(ctx: Context, g: Group, camera: str, top: str) -> frozenset[str]:
    """Classes under `top` a lone chain cannot be by the images declared on its links, where each declaration giving
    images is a plain camera (its type names no kind of camera: SDF's `camera`) publishing no depth: such a
    declaration renders one image, of a kind its type and format allow (stages.subparts.image_kinds), so the
    device's frames are one such image per declaration, and a class no such set of frames fits is out
    (Vocabulary.unfit: an RGB-D camera needs a colour and a depth or infrared frame), but the class of a catalogue
    product its links name. Nothing where a declaration names a kind of camera or none gives images."""
    vocab = ctx.vocab
    part = vocab.required_part(camera)
    if part is None:
        return frozenset()
    images = []
    for sensor in dict.fromkeys(s for link in g.members for s in ctx.tree.evidence.get(link, _NO_FACTS).sensors):
        kinds = image_kinds(vocab, sensor, part)
        if kinds is None:
            continue
        if {c for c in vocab.declared_classes([sensor.sdf_type]) if vocab.is_a(c, camera)} != {camera} or not kinds:
            return frozenset()
        images.append(kinds)
    if not images:
        return frozenset()
    out = frozenset.intersection(*(vocab.unfit(frozenset(frames), top) for frames in itertools.product(*images)))
    return out.intersection(vocab.subclasses_below(camera)) - _named_classes(ctx, g)


def _declared_first(ctx: Context, g: Group, start: str, counted: frozenset[str],
                    unfit: frozenset[str]) -> frozenset[str]:
    """The classes under `start` a multi-chain group is not offered: those its declarations, the catalogue product
    its links name (_off_product: a satellite receiver is a sensor of no kind the core names below Sensor), its count
    and its frames' kinds rule out; where together they leave none and the declarations narrowed, the frames' kinds
    (the model's reading of each frame) give way to the declarations (the file's statement of the device: a camera
    giving colour and a depth sensor make an RGB-D camera whose frames the model called depth only)."""
    key = f"post:{g.leaves[0]}"
    product = device_product(ctx.tree, g.chains)
    declared = (_ruled_out(ctx, ctx.tree, g.members, start, key, _classes_of(ctx.vocab, product))
                | _off_product(ctx.vocab, product, start))
    ruled_out = declared | counted
    offered = set(ctx.vocab.subclasses_below(start)) - ruled_out
    if declared and offered and offered <= unfit:
        ctx.log(f"{key}: its declarations leave no class its frames allow: the declarations stand")
        return ruled_out
    return ruled_out | unfit


def _frames_first(ctx: Context, found: Findings, groups: list[Group], start: str,
                  imaging: dict[int, list[str]], classified: bool = False) -> dict[int, frozenset[str]]:
    """The frames say the device: the part a `start` device requires (a camera's optical frame) is typed at
    each imaging leaf of `groups` first (`imaging`: a group's leaves that say what it is, by id; into
    `found.parts`), and each group is not offered the classes under `start`
    that the ontology says such parts rule out (Vocabulary.unfit: colour and depth frames make an RGB-D
    camera, a depth frame no monocular camera), except the class of a catalogue product the device names where
    only a part it needs is missing. For devices of several frames, and for a lone optical frame (frames.is_optical:
    one image, colour or depth, never a whole camera's): another lone link may stand for a whole camera (a RealSense
    written as one link), and its one answer cannot show colour and depth together. A lone frame is asked as
    sub-part typing would ask it, its pre-class (`classified`) as its device's: only an image that class cannot
    give changes it."""
    if not groups:
        return {}
    leaves = [leaf for g in groups for leaf in imaging[id(g)]]
    typed_as = {leaf: found.pre[leaf].cls for leaf in leaves} if classified else None
    frames = required_parts_first(ctx.oracle, ctx.vocab, ctx.tree, leaves, start, ctx.progress, typed_as)
    if not frames:
        return {}
    found.parts.update(frames)
    unfit = {}
    for g in groups:
        kinds = frozenset(frames[leaf].cls for leaf in imaging[id(g)])
        ruled = ctx.vocab.unfit(kinds, start)
        kept = {c for c in _named_classes(ctx, g) if not kinds & ctx.vocab.excluded_parts(c)}
        unfit[id(g)] = ruled - kept
        if unfit[id(g)]:
            ctx.log(f"post:{g.leaves[0]}: frames {sorted(kinds)}, so no {', '.join(sorted(unfit[id(g)]))}")
    return unfit


def _named_classes(ctx: Context, g: Group) -> frozenset[str]:
    """The class of the catalogue product the device's links name, and the classes above it: a part they need that
    no frame was typed as does not rule them out (the small model calls a product's monochrome stereo pair
    colour); a frame typed as a part they exclude still does (a depth frame, no stereo camera)."""
    return _classes_of(ctx.vocab, device_product(ctx.tree, g.chains))


def _classes_of(vocab: Vocabulary, product: Product | None) -> frozenset[str]:
    """A catalogue product's class and the classes above it; none for no product or a class the core lacks."""
    if product is None or product.cls not in vocab:
        return frozenset()
    return frozenset({product.cls, *vocab.ancestors(product.cls)})


def _imaging(ctx: Context, found: Findings, g: Group) -> list[str]:
    """The leaves that say what a device is: where some of its frames were called vision sensors and others
    not (a camera's own inertial and model frames, bound to it by group merging), the former; else all."""
    top = ctx.device_kind.cls
    seeing = [leaf for leaf in g.leaves if category(ctx, found.pre[leaf].cls, top) == VISION]
    return seeing or g.leaves


def _shared_class(ctx: Context, classes: set[str], top: str) -> str:
    """The deepest class every one of `classes` falls under (at most `top`), lifted off a leaf."""
    vocab = ctx.vocab
    common = [c for c in (top, *vocab.subclasses_below(top)) if all(vocab.is_a(x, c) for x in classes)]
    deepest = max(common, key=lambda c: len(vocab.ancestors(c)))
    return vocab.parents(deepest)[0] if vocab.is_leaf(deepest) and deepest != top else deepest


@step("numbered units", needs=("groups", "pre", "post"), makes=("groups", "post"))
def numbered_units(ctx: Context, found: Findings) -> None:
    """Units of one type given one device name are separate devices unless the device was classified as an array
    (core:numberedUnits): each hangs by its own joint from one parent, their names differing by a number only (each
    unit keeps its own pre-class), or, for a device of a kind other than vision (a camera's frames of several
    places are one device), in their last word only: a faceplate's button_1, button_2 and button_power, each unit
    of the device's class."""
    groups, post = [], []
    for g, t in zip(found.groups, found.post):
        if len(g.chains) < 2 or ctx.vocab.has_numbered_units(t.cls):
            groups.append(g)
            post.append(t)
        elif indexed_units(ctx.tree, g):
            ctx.log(f"split numbered units {g.leaves} ({t.cls} is not an array)")
            groups += [Group([c]) for c in g.chains]
            post += [found.pre[c.leaf] for c in g.chains]
        elif not ctx.vocab.is_a(t.cls, VISION) and indexed_units(ctx.tree, g, named_apart=True):
            ctx.log(f"split units named apart {g.leaves} (each a {t.cls}, which is not an array)")
            groups += [Group([c]) for c in g.chains]
            post += [t] * len(g.chains)
        else:
            groups.append(g)
            post.append(t)
    found.groups, found.post = groups, post


@step("sub-part typing", needs=("groups", "post", "parts"), makes=("parts",))
def subpart_typing(ctx: Context, found: Findings) -> None:
    """Each member link's sub-part class; the required parts post-classification typed first are kept
    (stages.subparts.type_subparts)."""
    found.parts = type_subparts(ctx.oracle, ctx.vocab, ctx.tree, ctx.device_kind, found.groups, found.post, None,
                                ctx.progress, found.parts)


@step("sub-part typing", needs=("groups", "post", "structures", "frozen_tips"), makes=("parts",))
def tool_subpart_typing(ctx: Context, found: Findings) -> None:
    """Each tool link's sub-part class, its structure (and its fingers written fixed) ruling classes out
    (stages.subparts.type_subparts)."""
    found.parts = type_subparts(ctx.oracle, ctx.vocab, ctx.tree, ctx.device_kind, found.groups, found.post,
                                found.structures, ctx.progress, frozen_tips=found.frozen_tips)
