"""Stage 1 for sensors, the sensor check: leaves identified as sensors that are none after all.

- A leaf that itself moves on a <mimic> joint is a finger segment or a linkage, never a sensor frame
  (a sensor is fixed to what carries it): it is left for the end-effector pass, whose tools keep
  every finger chain. So is a leaf moved by a joint other joints follow: it drives them (the horn or
  motor link that turns a gripper's fingers).
- Every other leaf identified as a sensor is asked once more, framed differently (sensor, emitter,
  drive part, reference frame or passive part?), unless the file declares a simulator sensor on it;
  alike leaves naming the same product (alike.alike_sets) once for all. "Part of a motor or drive" and "passive part"
  overrule identification: over the truth robots they went to motor screws, rotors, an actuator's
  dummy link, a battery, a reflector and links the truth ignores, and to no true sensor, while 'emitter'
  and 'reference frame' alone also took laser scanners and optical frames, so they are traced but change
  nothing. And a leaf
  that neither question calls a sensor with a majority of its votes (identification chose 'sensor'
  only as the largest minority, and the check gives it under half), with the two shares averaging
  below half by more than LAYOUT_NOISE, is not one: the model leans against it twice over, framed
  two ways. A leaf near a tie on both (a contact switch with no geometry often is) is kept: such a
  tie goes either way with the roundings of a KV layout, and a verdict must not.
"""
from __future__ import annotations

from urdfkb.pipeline.reading.evidence import named
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import DRIVE_PART, PASSIVE_PART, product_text, sensor_check
from urdfkb.pipeline.abstraction.stages.asking import Progress, ask
from urdfkb.pipeline.abstraction.stages.identification import named_product
from urdfkb.pipeline.abstraction.stages.verification import Log
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.abstraction.frames import declares_sensor
from urdfkb.pipeline.knowledge.ontology import Vocabulary
from urdfkb.pipeline.reading.tree import KinematicTree


def coupled(tree: KinematicTree, leaves: list[str], sensors: set[str], log: Log) -> list[str]:
    """The leaves among `sensors` that move on a <mimic> joint, or on a joint another one mimics."""
    drivers = {edge.mimic for edge in tree.edges if edge.mimic is not None}
    found = []
    for leaf in leaves:
        if leaf not in sensors:
            continue
        edge = tree.edge_to(leaf)
        if edge.mimic is not None:
            found.append(leaf)
            log(f"not a sensor: {leaf} moves on mimic joint {edge.joint}")
        elif edge.joint in drivers:
            found.append(leaf)
            log(f"not a sensor: {leaf} moves on joint {edge.joint}, which other joints follow")
    return found


MAJORITY = 0.5  # a share of the votes above which an answer is the model's majority view
# how far a share moves when only the KV layout of the same prompt changes: up to 0.11 over the truth
# robots' answers between two layouts (README, Accuracy and speed)
LAYOUT_NOISE = 0.1


def not_sensors(oracle: Oracle, vocab: Vocabulary, tree: KinematicTree, leaves: list[str], sensors: dict[str, float],
                log: Log, progress: Progress | None = None) -> list[str]:
    """The leaves among `sensors` (leaf → share of identification's votes for 'sensor') with no declared
    simulator sensor that the check calls a part of a motor or drive or a passive part, or that neither question calls a
    sensor with a majority while both lean clearly against it. The check is shown the catalogue product a leaf
    names, as identification was."""
    checked = [leaf for leaf in leaves if leaf in sensors and not declares_sensor(tree, leaf)]
    products = {leaf: named_product(tree, [leaf]) for leaf in checked}
    # asked once, the first standing for all, as in identification; leaves naming different products apart
    alike = alike_sets(tree, checked, lambda a, b: products[a] == products[b])
    questions = [sensor_check(group[0], named(tree.evidence, group[0]), tree.chain_to_root(group[0])[1:],
                              product_text(vocab, products[group[0]]))
                 for group in alike]
    found = []
    for group, verdict in zip(alike, ask(oracle, questions, "sensor check", progress)):
        leaf, checked_share = group[0], verdict.distribution.get("sensor", 0.0)
        if verdict.answer in (DRIVE_PART, PASSIVE_PART):
            found += group
            what = "a part of a motor or drive" if verdict.answer == DRIVE_PART else "a passive part"
            log(f"not a sensor: {', '.join(group)} is {what} ({verdict.confidence:.2f})")
        elif (max(sensors[leaf], checked_share) <= MAJORITY
              and (sensors[leaf] + checked_share) / 2 <= MAJORITY - LAYOUT_NOISE):
            found += group
            log(f"not a sensor: {', '.join(group)} is a sensor for a minority of the votes twice "
                f"(identification {sensors[leaf]:.2f}, check {checked_share:.2f})")
    return found
