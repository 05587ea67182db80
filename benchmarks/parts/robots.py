"""Parts x hosts as whole robots: built, and written as a truth folder `urdfkb eval` can score."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Iterator

import yaml

from benchmarks.parts.hosts import BUILD, Robot, hosts_for
from benchmarks.parts.library import Part


class _Dumper(yaml.SafeDumper):
    """Writes repeated lists out in full (no YAML anchors) so a truth file reads as the hand-written ones."""

    def ignore_aliases(self, data) -> bool:
        return True


def robots(parts: Iterable[Part], hosts: Iterable[str] | None = None) -> Iterator[tuple[Part, str, Robot]]:
    """Each part on each of its hosts (only those in `hosts`, when given)."""
    wanted = set(hosts) if hosts is not None else None
    for part in parts:
        for host in hosts_for(part):
            if wanted is None or host in wanted:
                yield part, host, BUILD[host](part)


def write(robot: Robot, part: Part, folder: Path) -> Path:
    """folder/urdf/<robot>.urdf and folder/eval/truth/<robot>.yaml (its URDF path relative to `folder`, as
    `urdfkb eval folder/eval/truth` reads it); returns the truth file."""
    (folder / "urdf").mkdir(parents=True, exist_ok=True)
    (folder / "eval" / "truth").mkdir(parents=True, exist_ok=True)
    urdf = f"urdf/{robot.name}.urdf"
    (folder / urdf).write_bytes(robot.urdf())
    src = part.source
    head = (f"# {part.product} ({part.maker}) on the generated '{robot.name.split('__')[1]}' host. Part: github "
            f"{src['repo']}@{src['commit'][:7]} : {src['file']} ({src['licence']}), described in "
            f"benchmarks/parts/data/{part.key}.yaml.\n")
    truth = folder / "eval" / "truth" / f"{robot.name}.yaml"
    truth.write_text(head + yaml.dump(robot.truth(urdf), Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=140))
    return truth
