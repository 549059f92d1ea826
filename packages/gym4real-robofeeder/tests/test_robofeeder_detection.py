"""The classical detector on rendered scenes, the detector interface and the crop procedure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gym4real.core.errors import ConfigError, DataFileError
from gym4real.robofeeder.config import PickingConfig
from gym4real.robofeeder.detection import ClassicalDetector, OnnxDetector, crop, make_detector
from gym4real.robofeeder.simulator import Simulator


@pytest.fixture(scope="module")
def sim():
    s = Simulator(PickingConfig.build(n_objects=3))
    yield s
    s.close()


@pytest.mark.parametrize("seed", range(8))
def test_finds_every_spawned_object(sim, seed: int) -> None:
    sim.reset(np.random.default_rng(seed))
    detections = ClassicalDetector().detect(sim.render("top_down"))
    assert len(detections) == 3
    cam = sim.camera
    # the true silhouette centres (from the mesh and the simulated pose), seen through the camera
    true_xy = cam.pixel_to_world(cam.world_to_pixel(sim.object_centres()))
    found_xy = cam.pixel_to_world(np.array([d.centre for d in detections]))
    for xy in true_xy:
        assert np.linalg.norm(found_xy - xy, axis=1).min() < 2e-3


def test_empty_bin_has_no_detection(sim) -> None:
    sim.reset(np.random.default_rng(0), placements=np.array([[0.0, 5.0], [0.5, 5.0], [-0.5, 5.0]]))
    assert ClassicalDetector().detect(sim.render("top_down")) == []


def test_detections_are_sorted_and_boxed() -> None:
    frame = np.zeros((100, 100, 3), np.uint8)
    frame[10:20, 10:40] = 255  # 300 px
    frame[60:70, 60:70] = 200  # 100 px
    dets = ClassicalDetector().detect(frame)
    assert [d.box for d in dets] == [(8, 8, 42, 22), (58, 58, 72, 72)]  # dilated by 2 px
    assert dets[0].score > dets[1].score
    assert dets[0].centre == pytest.approx((24.5, 14.5), abs=0.01)


def test_crop_window_and_clamping() -> None:
    frame = np.zeros((300, 300, 3), np.uint8)
    frame[100:120, 100:130] = 255
    patch, centre = crop(frame, (100, 100, 130, 120))
    assert patch.shape == (50, 50) and patch.dtype == np.float32
    assert tuple(centre) == (115.0, 110.0)
    assert patch.max() == pytest.approx(1.0, abs=1e-3) and patch.min() == 0.0
    # near the left edge: the corrected window is shifted by the horizontal margin only
    frame2 = np.zeros((300, 300, 3), np.uint8)
    frame2[0:50, 0:50] = np.arange(50, dtype=np.uint8)[None, :, None] * 5
    fixed, _ = crop(frame2, (5, 100, 25, 150))
    upstream, _ = crop(frame2, (5, 100, 25, 150), per_axis=False)
    assert fixed.shape == upstream.shape == (50, 50)


def test_detector_factory_errors(tmp_path: Path) -> None:
    assert isinstance(make_detector("classical", 150, 20, lambda: np.zeros((0, 2))), ClassicalDetector)
    with pytest.raises(ConfigError, match="detector"):
        make_detector("ssd", 150, 20, lambda: np.zeros((0, 2)))
    empty = tmp_path / "objDetection.onnx"
    empty.write_bytes(b"")  # the reference's detector file is empty
    with pytest.raises(DataFileError, match="empty"):
        OnnxDetector(empty)


def test_onnx_detector_layout(tmp_path: Path) -> None:
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper

    boxes = np.array([[[0.1, 0.2, 0.3, 0.4], [0.5, 0.5, 0.6, 0.7]]], np.float32)
    scores = np.array([[0.9, 0.1]], np.float32)
    graph = helper.make_graph(
        [
            helper.make_node("Constant", [], ["detection_boxes"], value=onnx.numpy_helper.from_array(boxes)),
            helper.make_node("Constant", [], ["detection_scores"], value=onnx.numpy_helper.from_array(scores)),
            helper.make_node("Identity", ["input_tensor"], ["raw"]),
        ],
        "tfod",
        [helper.make_tensor_value_info("input_tensor", TensorProto.UINT8, [1, 300, 300, 3])],
        [
            helper.make_tensor_value_info("raw", TensorProto.UINT8, [1, 300, 300, 3]),
            helper.make_tensor_value_info("detection_boxes", TensorProto.FLOAT, [1, 2, 4]),
            helper.make_tensor_value_info("detection_scores", TensorProto.FLOAT, [1, 2]),
        ],
    )
    path = tmp_path / "det.onnx"
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, str(path))
    dets = OnnxDetector(path).detect(np.zeros((300, 300, 3), np.uint8))
    assert [d.box for d in dets] == [(60, 30, 120, 90)]  # (ymin, xmin, ymax, xmax) -> pixels, low score dropped


@settings(max_examples=150, deadline=None)
@given(
    x0=st.integers(0, 290), y0=st.integers(0, 290), w=st.integers(2, 80), h=st.integers(2, 80), per_axis=st.booleans()
)
def test_crop_is_always_a_valid_patch(x0: int, y0: int, w: int, h: int, per_axis: bool) -> None:
    frame = np.random.default_rng(x0 + 1000 * y0).integers(0, 256, (300, 300, 3), dtype=np.uint8)
    box = (x0, y0, min(x0 + w, 300), min(y0 + h, 300))
    patch, centre = crop(frame, box, per_axis=per_axis)
    assert patch.shape == (50, 50) and patch.dtype == np.float32
    assert patch.min() >= 0.0 and patch.max() <= 1.0
    assert tuple(centre) == ((box[0] + box[2]) / 2, (box[1] + box[3]) / 2)
    if per_axis and w <= 40 and h <= 40 and 30 <= x0 <= 220 and 30 <= y0 <= 220:
        # inside the frame, a small box is padded to exactly 50 px around its centre: no resampling
        dx, dy = round((50 - (box[2] - box[0])) / 2), round((50 - (box[3] - box[1])) / 2)
        window = frame[box[1] - dy : box[3] + dy, box[0] - dx : box[2] + dx]
        if window.shape[:2] == (50, 50):
            np.testing.assert_allclose(
                patch, window.astype(np.float32) @ np.float32([0.2989, 0.587, 0.114]) / 255, atol=1e-6
            )
