"""Random but plausible camera heads, with the truth of which frames make one device.

A mount link carries 1-4 camera housings (a box each), fixed at random places and facing random
directions at least 45 degrees apart, or, sometimes, a stereo pair: two housings side by side
(0.05-0.2 m apart) facing the same way. Each housing carries 1-4 optical frames (pure frames, the
leaves); with `bare=True` each housing is a bare frame instead (no geometry: a device's own frame that its
optical frames hang from, as many lidars and cameras are written). Every frame's name is one shared stem plus a meaningless word, so a model that reads names
could call every frame one device: what keeps devices apart here is structure alone.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass

from tests.urdf_writer import Writer


@dataclass
class Built:
    urdf: bytes
    mount: str
    stem: str                    # the name stem every frame shares
    devices: list[list[str]]     # the frames (leaves) of each true device
    housing: dict[str, str]      # frame -> its housing link
    description: str


def build(seed: int, bare: bool = False) -> Built:
    """One random camera head; the same seed builds the same robot (`bare`: with bare-frame housings)."""
    rng = random.Random(seed)
    w = Writer(rng)
    mount = w.link("<box size=\"0.3 0.3 0.1\"/>")
    stem = w.name()
    stereo = rng.random() < 0.3
    count = rng.randint(1, 4)
    yaws: list[float] = []
    while len(yaws) < count:  # facing directions at least 45 degrees apart
        yaw = rng.uniform(-math.pi, math.pi)
        if all(abs(math.remainder(yaw - other, 2 * math.pi)) >= math.radians(45) for other in yaws):
            yaws.append(yaw)
    devices: list[list[str]] = []
    housing: dict[str, str] = {}

    def camera(xyz, yaw) -> list[str]:
        body = w.link("" if bare else "<box size=\"0.03 0.1 0.03\"/>")
        w.joint("fixed", mount, body, xyz, rpy=(0.0, 0.0, yaw))
        frames = []
        for _ in range(rng.randint(1, 4)):
            frame = f"{stem}_{w.name()}"
            w.links.append(f'<link name="{frame}"/>')
            w.joint("fixed", body, frame, (0.0, rng.uniform(-0.04, 0.04), 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
            frames.append(frame)
            housing[frame] = body
        return frames

    for yaw in yaws:
        radius = rng.uniform(0.1, 0.3)
        devices.append(camera((radius * math.cos(yaw), radius * math.sin(yaw), 0.08), yaw))
    if stereo:
        yaw = rng.uniform(-math.pi, math.pi)
        centre = (0.0, 0.0, rng.uniform(0.4, 0.6))  # above the others, on a mast
        half = rng.uniform(0.025, 0.1)
        side = (-math.sin(yaw) * half, math.cos(yaw) * half, 0.0)
        left = camera(tuple(c + s for c, s in zip(centre, side)), yaw)
        right = camera(tuple(c - s for c, s in zip(centre, side)), yaw)
        devices.append(left + right)
    description = f"{count} camera(s)" + (" and a stereo pair" if stereo else "") + (", bare housings" if bare else "")
    return Built(w.urdf(), mount, stem, devices, housing, description)
