"""What ships: the sdist built from the checkout, the wheel built from that sdist, installed into a fresh venv,
runs `urdfkb --help` and a structure-only populate from its own files (the symlinked folders shipped as files)."""
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "kb_server" / "samples" / "turtlebot3_waffle_pi.urdf"

pytestmark = pytest.mark.slow


def _run(*args: str | Path, cwd: Path) -> str:
    proc = subprocess.run([str(a) for a in args], cwd=cwd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"{args}: {proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    return proc.stdout


def test_sdist_to_wheel_to_a_fresh_venv(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    _run(sys.executable, "-m", "build", "--outdir", dist, REPO, cwd=tmp_path)  # the sdist, then the wheel from it
    wheel = next(dist.glob("urdfkb-*.whl"))
    shipped = set(zipfile.ZipFile(wheel).namelist())
    for module in ("urdfkb/pipeline/runner.py", "urdfkb/kb_server/cli.py", "urdfkb/ontologies/urdfkb.owl",
                   "urdfkb/queries/cameras.rq", "urdfkb/kb_server/templates/base.html"):
        assert module in shipped, module
    assert not any(name.startswith(("pipeline/", "kb_server/", "tests/")) for name in shipped)

    venv = tmp_path / "venv"
    _run(sys.executable, "-m", "venv", "--without-pip", venv, cwd=tmp_path)
    python = venv / "bin" / "python"
    _run(sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-deps", wheel, cwd=tmp_path)
    # The dependencies come from this environment's site-packages, as a path entry (its .pth files, the editable
    # install's among them, are not read): urdfkb itself can only come from the wheel.
    site = Path(_run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])", cwd=tmp_path).strip())
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    where = _run(python, "-c", "import urdfkb.pipeline.runner as r; print(r.__file__)", cwd=tmp_path).strip()
    assert Path(where).is_relative_to(venv), where
    assert "populate" in _run(venv / "bin" / "urdfkb", "--help", cwd=tmp_path)
    out = tmp_path / "waffle.ttl"
    _run(venv / "bin" / "urdfkb", "populate", SAMPLE, "--structure-only", "-o", out, cwd=tmp_path)
    assert "hasComponent" in out.read_text()
