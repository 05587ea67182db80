"""Rotations as URDF and SDF write them (roll, pitch, yaw about fixed x, y, z), shared by the tree and the evidence."""
from __future__ import annotations

from math import cos, sin


def rotate_rpy(rpy: tuple[float, float, float], v: tuple[float, float, float]) -> tuple[float, float, float]:
    """Apply R = Rz(yaw) Ry(pitch) Rx(roll) to v."""
    roll, pitch, yaw = rpy
    x, y, z = v
    y, z = cos(roll) * y - sin(roll) * z, sin(roll) * y + cos(roll) * z
    x, z = cos(pitch) * x + sin(pitch) * z, -sin(pitch) * x + cos(pitch) * z
    x, y = cos(yaw) * x - sin(yaw) * y, sin(yaw) * x + cos(yaw) * y
    return (x, y, z)
