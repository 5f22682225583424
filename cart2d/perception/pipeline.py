"""Perception for the gateway, one frame at a time: a JPEG from the camera and the cart's pose
at its capture -> obstacle hits and the camera's field of view in map coordinates, the occupancy
grid updated, and what to draw on the picture the panel shows.

The gateway's camera feed calls `process` from its frame hook (returning
Overlay(draw=perceived.draw)); the perceived cells (`cells()`, p > 0.5) go to
Gateway.set_perceived and the hits and field of view to /ws.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import CameraCalibration, load_calibration
from cart2d.perception.camera_model import FloatArray, Mount
from cart2d.perception.detection import Detection, DetectorConfig, ObstacleDetector, draw_detection
from cart2d.perception.occupancy import LogOddsGrid, Pose
from cart2d.perception.parallax import ParallaxCue


@dataclass
class Perceived:
    """One frame's result in map coordinates (m)."""

    hits: FloatArray  # N x 2
    fov: FloatArray  # the field of view's polygon, K x 2
    detection: Detection  # in base_link

    def draw(self, canvas: npt.NDArray[np.uint8]) -> None:
        """Draws the detection on (a copy of) its frame, in place: the camera feed's Overlay.draw."""
        draw_detection(canvas, self.detection)


def to_map(points: FloatArray, pose: Pose) -> FloatArray:
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    return np.asarray(np.reshape(points, (-1, 2)) @ np.array([[c, s], [-s, c]]) + [x, y], dtype=np.float64)


class Perception:
    def __init__(
        self,
        grid: LogOddsGrid,
        calibration: CameraCalibration | None = None,
        mount: Mount | None = None,
        config: DetectorConfig | None = None,
    ) -> None:
        self.mount = mount or Mount.from_robot()
        self.calibration = calibration or load_calibration(mount=self.mount)
        self.detector = ObstacleDetector(self.calibration, self.mount, config)
        self.parallax = ParallaxCue(self.calibration)
        self.grid = grid
        self.fov_base = self.detector.field_of_view()

    def process(self, bgr: npt.NDArray[np.uint8], pose: Pose, heading_sigma: float = 0.0) -> Perceived:
        """A decoded frame and the cart's pose (x, y, theta in the map) when it was captured,
        its heading uncertain by `heading_sigma` (rad): the parallax cue compares it with an
        earlier frame through the floor's homography the two poses give
        (cart2d/perception/parallax.py)."""
        detection = self.detector.detect(bgr, self.parallax.observe(bgr, pose))
        self.grid.integrate(pose, detection, heading_sigma)
        return Perceived(to_map(detection.hits, pose), to_map(self.fov_base, pose), detection)

    def process_jpeg(self, jpeg: bytes, pose: Pose) -> Perceived:
        """ValueError if `jpeg` is not a JPEG of the calibration's size."""
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            raise ValueError("not a JPEG")
        return self.process(np.asarray(image, dtype=np.uint8), pose)

    def cells(self, threshold: float = 0.5) -> list[tuple[float, float, float]]:
        return self.grid.cells(threshold)

    def clear(self) -> None:
        self.grid.clear()
        self.parallax.reset()
