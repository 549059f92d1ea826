"""Object detection on the top-down frame and the reference's crop procedure.

The reference's SSD MobileNet detector is missing from its snapshot (defect 1), so the default is a
deterministic classical detector: bright pixels (gray > 150), a 5x5 dilation, external contours,
blobs of at least 20 px, sorted by area; each detection has an axis-aligned box (the TF-OD layout the
crops use), an oriented box (``cv2.minAreaRect``) and the blob's centroid, which locates the part (it is
the centroid of the part's silhouette seen from above, within about 1 mm). Any object with
``detect(rgb) -> list[Detection]`` can replace it; :class:`OnnxDetector` runs an ONNX model with the
TF Object-Detection-API layout, :class:`OracleDetector` projects the true poses (for tests).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from gym4real.core.errors import ConfigError, DataFileError
from gym4real.core.install_hint import require
from gym4real.robofeeder.rendering import grayscale

cv2 = require("cv2", "gym4real-robofeeder", "opencv-python-headless")


@dataclass(frozen=True)
class Detection:
    """One detected object, in pixels of the frame.

    Attributes:
        box: Axis-aligned box (x_min, y_min, x_max, y_max), integers as the reference crops use them.
        centre: Centroid (u, v) of the blob (float).
        angle: Orientation of the oriented box (degrees, OpenCV's ``minAreaRect`` convention).
        size: Sides of the oriented box (px).
        score: Area (classical), confidence (ONNX) or 1 (oracle); detections are sorted by it.
    """

    box: tuple[int, int, int, int]
    centre: tuple[float, float]
    angle: float = 0.0
    size: tuple[float, float] = (0.0, 0.0)
    score: float = 1.0


class Detector(Protocol):
    """What the environments call: detections of an RGB frame, best first."""

    def detect(self, rgb: np.ndarray) -> list[Detection]:
        """Return the detections of ``rgb`` (uint8, H x W x 3), best first."""
        ...


class ClassicalDetector:
    """Threshold, dilate, contours and oriented boxes (OpenCV).

    Args:
        threshold: Gray level (0-255) above which a pixel belongs to a part.
        min_area: Smallest blob (px, after dilation) kept.
        dilate: Side of the square dilation kernel (px).
    """

    def __init__(self, threshold: int = 150, min_area: int = 20, dilate: int = 5) -> None:
        self.threshold = threshold
        self.min_area = min_area
        self.kernel = np.ones((dilate, dilate), np.uint8)

    def detect(self, rgb: np.ndarray) -> list[Detection]:
        """Bright blobs of the frame, largest first; the centre is the blob's centroid (its silhouette's)."""
        gray = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
        mask = cv2.dilate((gray > self.threshold).astype(np.uint8), self.kernel)
        count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        out = []
        for k in range(1, count):
            x, y, w, h, area = (int(v) for v in stats[k])
            if area < self.min_area:
                continue
            points = cv2.findNonZero((labels[y : y + h, x : x + w] == k).astype(np.uint8)) + np.array([x, y])
            _, (sw, sh), angle = cv2.minAreaRect(points.astype(np.float32))
            out.append(
                Detection(
                    box=(x, y, x + w, y + h),
                    centre=(float(centroids[k][0]), float(centroids[k][1])),
                    angle=float(angle),
                    size=(float(sw), float(sh)),
                    score=float(area),
                )
            )
        out.sort(key=lambda d: (-d.score, d.centre))
        return out


class OracleDetector:
    """Detections from the true object poses projected through the camera (for tests and ablations).

    Args:
        truth: Callable returning the pixel centres (K x 2) of the objects still in the bin.
        half_size: Half side (px) of the square box around each centre.
    """

    def __init__(self, truth: Callable[[], np.ndarray], half_size: int = 18) -> None:
        self.truth = truth
        self.half_size = half_size

    def detect(self, rgb: np.ndarray) -> list[Detection]:
        """Boxes around the projected centres of the objects inside the frame."""
        h, w = rgb.shape[:2]
        out = []
        for u, v in np.asarray(self.truth(), dtype=float).reshape(-1, 2):
            if 0 <= u < w and 0 <= v < h:
                box = (
                    int(u) - self.half_size,
                    int(v) - self.half_size,
                    int(u) + self.half_size,
                    int(v) + self.half_size,
                )
                out.append(Detection(box=box, centre=(float(u), float(v))))
        return out


class OnnxDetector:
    """An ONNX detector with the TF Object-Detection-API layout the reference expects.

    Input ``input_tensor``: uint8 RGB (1, H, W, 3). Outputs: ``detection_boxes`` (1, K, 4) normalised
    (y_min, x_min, y_max, x_max) sorted by score (by name, else output index 1 as the reference reads it),
    and ``detection_scores`` (1, K) if present. The model's declared signature is checked when it is
    loaded: a model of another kind (a classifier, a float input, channels first) is refused then, with
    what it declares, rather than at the first frame.

    Args:
        path: The ``.onnx`` file.
        min_score: Detections scoring below this are dropped (when scores are available).
    """

    def __init__(self, path: str | Path, min_score: float = 0.5) -> None:
        ort = require("onnxruntime", "gym4real-robofeeder", "onnxruntime")
        path = Path(path)
        if not path.is_file() or path.stat().st_size == 0:
            msg = f'ONNX detector `{path}` is missing or empty; pass `detector="classical"` or a valid model'
            raise DataFileError(msg)
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        try:
            self.session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        except Exception as exc:
            raise DataFileError(f"cannot load the ONNX detector `{path}`: {exc}") from exc
        self.input = self.session.get_inputs()[0].name
        names = [o.name for o in self.session.get_outputs()]
        self.box_output = "detection_boxes" if "detection_boxes" in names else names[min(1, len(names) - 1)]
        self.score_output = "detection_scores" if "detection_scores" in names else None
        self.min_score = min_score
        self._check_signature(path)

    def _check_signature(self, path: Path) -> None:
        """Refuse a model whose declared input or outputs do not have the TF-OD layout."""
        inputs = self.session.get_inputs()
        outputs = {o.name: o for o in self.session.get_outputs()}
        problems = []
        image = inputs[0]
        if len(inputs) != 1 or image.type != "tensor(uint8)" or not _fits(image.shape, (1, None, None, 3)):
            got = ", ".join(f"`{i.name}` {i.type} {i.shape}" for i in inputs)
            problems.append(f"its input is {got}; expected one tensor(uint8) of shape (1, H, W, 3), an RGB image")
        boxes = outputs[self.box_output]
        if boxes.type != "tensor(float)" or not _fits(boxes.shape, (1, None, 4)):
            problems.append(
                f"its box output `{boxes.name}` is {boxes.type} {boxes.shape}; expected `detection_boxes`, "
                "tensor(float) of shape (1, K, 4)"
            )
        if self.score_output and not _fits(outputs[self.score_output].shape, (1, None)):
            problems.append(f"`detection_scores` has shape {outputs[self.score_output].shape}; expected (1, K)")
        if problems:
            msg = (
                f"ONNX detector `{path}` is not an object detector with the TF Object-Detection layout: "
                f"{'; '.join(problems)}. Fix: export the detector with that layout, or use "
                '`detector="classical"`'
            )
            raise DataFileError(msg)

    def detect(self, rgb: np.ndarray) -> list[Detection]:
        """Boxes of the model, in its score order."""
        h, w = rgb.shape[:2]
        wanted = [self.box_output] + ([self.score_output] if self.score_output else [])
        result = self.session.run(wanted, {self.input: np.ascontiguousarray(rgb, dtype=np.uint8)[None]})
        boxes = np.asarray(result[0]).reshape(-1, 4)
        scores = np.asarray(result[1]).reshape(-1) if self.score_output else np.ones(len(boxes))
        out = []
        for (y0, x0, y1, x1), score in zip(boxes, scores, strict=True):
            if score < self.min_score or x1 <= x0 or y1 <= y0:
                continue
            box = (int(x0 * w), int(y0 * h), int(x1 * w), int(y1 * h))
            out.append(Detection(box=box, centre=((box[0] + box[2]) / 2, (box[1] + box[3]) / 2), score=float(score)))
        return out


def _fits(shape: list[int | str | None] | None, wanted: tuple[int | None, ...]) -> bool:
    """Whether a declared ONNX shape can be ``wanted`` (None: any size; a symbolic or unknown dim fits anything)."""
    if shape is None:
        return True
    if len(shape) != len(wanted):
        return False
    return all(w is None or not isinstance(d, int) or d == w for d, w in zip(shape, wanted, strict=True))


def make_detector(spec: str, threshold: int, min_area: int, truth: Callable[[], np.ndarray]) -> Detector:
    """The detector named by the config: ``classical``, ``oracle`` or an ONNX path."""
    if spec == "classical":
        return ClassicalDetector(threshold, min_area)
    if spec == "oracle":
        return OracleDetector(truth)
    if spec.endswith(".onnx"):
        return OnnxDetector(spec)
    raise ConfigError(f'unknown `detector` {spec!r}; expected "classical", "oracle" or the path of a `.onnx` file')


def crop(
    rgb: np.ndarray, box: tuple[int, int, int, int], size: int = 50, *, per_axis: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """The reference's crop: a ``size`` window around ``box``, resized (nearest), grayscale in [0, 1].

    Args:
        rgb: The frame (uint8, H x W x 3).
        box: (x_min, y_min, x_max, y_max) in pixels.
        size: Side of the crop.
        per_axis: Shift a window that leaves the frame back inside per axis (corrected); False reproduces
            the reference, whose left-edge branch shifts by the vertical margin (defect 9).

    Returns:
        (crop (size x size, float32), centre (u, v) of the box).
    """
    h, w = rgb.shape[:2]
    x0, y0, x1, y1 = box
    centre = np.array([(x0 + x1) / 2.0, (y0 + y1) / 2.0])
    dx = round((size - (x1 - x0)) / 2)
    dy = round((size - (y1 - y0)) / 2)
    left, right, top, bottom = x0 - dx, x1 + dx, y0 - dy, y1 + dy
    if left < 0:
        shift = -left if per_axis else max(-left, dy)
        left, right = left + shift, right + shift
    if right > w:
        left, right = left - (right - w), w
    if top < 0:
        top, bottom = 0, bottom - top
    if bottom > h:
        top, bottom = top - (bottom - h), h
    left, top = max(left, 0), max(top, 0)
    window = rgb[top:bottom, left:right]
    if window.size == 0:
        return np.zeros((size, size), np.float32), centre
    window = cv2.resize(np.ascontiguousarray(window), (size, size), interpolation=cv2.INTER_NEAREST)
    return grayscale(window), centre
