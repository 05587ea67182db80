"""Arithmetic on 3-vectors written as tuples, as the kinematic tree holds them (pipeline.reading.tree.Vector)."""
from __future__ import annotations

import math

from urdfkb.pipeline.reading.tree import Vector


def dot(a: Vector, b: Vector) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(v: Vector) -> float:
    return math.sqrt(sum(x * x for x in v))


def unit(v: Vector) -> Vector | None:
    """`v` scaled to length 1; None for the zero vector."""
    n = norm(v)
    return None if n == 0 else (v[0] / n, v[1] / n, v[2] / n)


def cross(a: Vector, b: tuple[float, ...]) -> Vector:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def off_axis(v: Vector, axis: Vector) -> float:
    """How far the point `v` lies from the line through the origin along the unit `axis` (0 anywhere on it)."""
    return norm(cross(v, axis))


def sub(a: Vector, b: Vector) -> Vector:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def turn(v: Vector, axis: Vector, angle: float) -> Vector:
    """Rodrigues' rotation of v about a unit axis."""
    c, s = math.cos(angle), math.sin(angle)
    k = cross(axis, v)
    d = dot(axis, v) * (1 - c)
    return (v[0] * c + k[0] * s + axis[0] * d, v[1] * c + k[1] * s + axis[1] * d, v[2] * c + k[2] * s + axis[2] * d)
