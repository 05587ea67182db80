"""The sample robot of `make run` (TurtleBot3 Waffle Pi), abstracted by the real default model.

Skipped where the default model (Qwen2.5-Coder-1.5B, 1.1 GB) has not been fetched: `urdfkb model`
fetches it. `make run` fetches it, and so does CI's machine before the closing run.
"""
from pathlib import Path

import pytest

from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, models_dir, ensure_model
from urdfkb.pipeline.runner import Settings, run

pytestmark = [pytest.mark.model, pytest.mark.default_model]
SENSOR_LEAVES = {"base_scan", "imu_link", "camera_rgb_optical_frame"}
SAMPLE = Path(__file__).resolve().parents[1] / "kb_server" / "samples" / "turtlebot3_waffle_pi.urdf"


@pytest.fixture(scope="module")
def abstraction():
    if not (models_dir() / DEFAULT_MODEL.filename).is_file():
        pytest.skip(f"default model not fetched ({models_dir() / DEFAULT_MODEL.filename}); run `urdfkb model`")
    model = ensure_model(DEFAULT_MODEL, progress=False)
    return run(load_urdf(SAMPLE), Settings(model=str(model), use_cache=False))


def test_the_sample_robot_has_a_lidar_an_imu_and_a_monocular_camera_on_its_base(abstraction):
    got = {c.cls: (c.root, {s.link for s in c.subcomponents} & SENSOR_LEAVES) for c in abstraction.components}
    assert len(abstraction.components) == 3
    assert got == {"Lidar": ("base_link", {"base_scan"}), "IMU": ("base_link", {"imu_link"}),
                   "MonocularCamera": ("base_link", {"camera_rgb_optical_frame"})}
