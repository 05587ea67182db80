"""The URDF writer of the generated test robots (tests/body_robots.py, tests/hand_robots.py)."""
from __future__ import annotations

import random


def _number(x: float) -> str:
    return f"{x:.5f}".rstrip("0").rstrip(".") or "0"


def _vector(v) -> str:
    return " ".join(map(_number, v))


class Writer:
    """Builds a URDF of seeded random, meaningless, distinct link and joint names."""

    def __init__(self, rng: random.Random):
        self.rng = rng
        self.links: list[str] = []
        self.joints: list[str] = []
        self.used: set[str] = set()

    def name(self) -> str:
        while True:
            stem = "".join(self.rng.choice("bcdfghjkmnpqrstvwxz") + self.rng.choice("aeiou") for _ in range(3))
            if stem not in self.used:
                self.used.add(stem)
                return stem

    def arm(self, base: str) -> str:
        """Six revolute links up from `base` (yaw, pitch, pitch in turn, 0.1 to 0.3 m apart): an arm's last link."""
        link = base
        for i, z in enumerate((0.2, 0.1, 0.3, 0.1, 0.25, 0.1)):
            child = self.link('<box size="0.05 0.05 0.2"/>')
            self.joint("revolute", link, child, (0.0, 0.0, z), (0.0, 0.0, 1.0) if i % 3 == 0 else (0.0, 1.0, 0.0))
            link = child
        return link

    def link(self, geometry: str = "", collision: str = "", centre=None, mass: float = 0.1, at=None) -> str:
        """A new link; `geometry` (a URDF geometry element) gives it a visual (drawn at `at`, else at its origin),
        `collision` a collision shape, `centre` an <inertial> of `mass` with its centre of mass there."""
        name = self.name()
        origin = f'<origin xyz="{_vector(at)}"/>' if at is not None else ""
        visual = f"<visual>{origin}<geometry>{geometry}</geometry></visual>" if geometry else ""
        shape = f"<collision><geometry>{collision}</geometry></collision>" if collision else ""
        inertial = (f'<inertial><origin xyz="{_vector(centre)}"/><mass value="{_number(mass)}"/>'
                    '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>'
                    if centre is not None else "")
        self.links.append(f'<link name="{name}">{visual}{shape}{inertial}</link>')
        return name

    def joint(self, kind: str, parent: str, child: str, xyz=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0),
              limits: tuple[float, float] | None = None, mimic: str | None = None, multiplier: float = 1.0,
              rpy=(0.0, 0.0, 0.0), unlimited: bool = False, unwritten: bool = False) -> str:
        """A new joint; `unlimited` writes a <limit> with no range (a simulator's revolute joint that turns freely),
        `unwritten` one of all zeros (a hand-written file's placeholder: lower, upper, effort and velocity 0)."""
        name = self.name()
        limit = ""
        if unlimited:
            limit = '<limit effort="10" velocity="1"/>'
        elif unwritten:
            limit = '<limit effort="0" lower="0" upper="0" velocity="0"/>'
        elif kind in ("revolute", "prismatic") or (kind == "continuous" and limits):  # files bound linkage bars so
            lo, hi = limits or (-1.0, 1.0)
            limit = f'<limit lower="{_number(lo)}" upper="{_number(hi)}" effort="10" velocity="1"/>'
        mimic_tag = f'<mimic joint="{mimic}" multiplier="{multiplier}" offset="0"/>' if mimic else ""
        axis_tag = "" if kind == "fixed" else f'<axis xyz="{_vector(axis)}"/>'
        self.joints.append(
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{_vector(xyz)}" rpy="{_vector(rpy)}"/>'
            f'{axis_tag}{limit}{mimic_tag}</joint>')
        return name

    def urdf(self) -> bytes:
        return f'<robot name="{self.name()}">{"".join(self.links)}{"".join(self.joints)}</robot>'.encode()
