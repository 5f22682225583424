"""Hand annotations of pictures (tests/data/real/README.md has the format) and how a detection
scores against them: which obstacles it found, how far off their feet, what it took for an
obstacle on open floor, and whether it took a shadow for one.

An obstacle is found when, on at least a third of the columns its foot spans, a scan line's hit
lies within `tolerance_px` (10 pixels at QVGA, scaled with the picture's width) of the annotated
foot. A false hit is a scan line's hit inside the floor's polygon, more than the tolerance from
its edge (the edge is where the annotated feet are). A shadow is taken for an obstacle when at
least SHADOW_LINES scan lines hit inside it.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.camera_file import detect_pair, load_camera, read_picture
from cart2d.perception.detection import Detection, ObstacleDetector
from cart2d.perception.parallax import ParallaxCue

QVGA_WIDTH = 320
TOLERANCE_QVGA_PX = 10.0
FOUND_SHARE = 1.0 / 3.0
SHADOW_LINES = 3


@dataclass(frozen=True)
class Obstacle:
    kind: str
    foot: npt.NDArray[np.float64]  # K x 2 pixels (u, v), left to right


@dataclass(frozen=True)
class Annotation:
    path: Path  # the JSON file
    image: Path
    before: Path | None  # an earlier frame of the same drive, if there is one
    camera: Path
    source: str
    floor_kind: str
    floor: npt.NDArray[np.float64]  # the floor's polygon, pixels
    obstacles: list[Obstacle]
    shadows: list[npt.NDArray[np.float64]] = field(default_factory=list)

    @classmethod
    def load(cls, path: Path, pictures: Path | None = None) -> Annotation:
        """ValueError with a sentence if `path` is not an annotation. `pictures`: the folder of
        the pictures it names (None: beside it)."""
        try:
            d: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
            here = path.parent
            shown = here if pictures is None else pictures
            return cls(
                path=path,
                image=shown / str(d["image"]),
                before=None if d.get("before") is None else shown / str(d["before"]),
                camera=here / str(d["camera"]),
                source=str(d["source"]),
                floor_kind=str(d["floor"]["kind"]),
                floor=np.array(d["floor"]["polygon"], dtype=np.float64).reshape(-1, 2),
                obstacles=[
                    Obstacle(str(o["kind"]), np.array(sorted(o["foot"]), dtype=np.float64).reshape(-1, 2))
                    for o in d["obstacles"]
                ],
                shadows=[
                    np.array(s["polygon"], dtype=np.float64).reshape(-1, 2) for s in d.get("shadows", [])
                ],
            )
        except (OSError, KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: not an annotation ({exc})") from exc


@dataclass
class ObstacleScore:
    kind: str
    columns: int
    found_columns: int
    foot_error_px: float  # median over the found columns; NaN if none

    @property
    def found(self) -> bool:
        return self.columns > 0 and self.found_columns >= FOUND_SHARE * self.columns


@dataclass
class Score:
    obstacles: list[ObstacleScore]
    lines: int  # scan lines looked at
    false_hit_lines: int
    shadow_hit_lines: list[int]  # per annotated shadow

    @property
    def false_hit_share(self) -> float:
        return self.false_hit_lines / max(self.lines, 1)

    @property
    def shadows_taken(self) -> int:
        return sum(1 for n in self.shadow_hit_lines if n >= SHADOW_LINES)


def _inside(
    polygon: npt.NDArray[np.float64], size: tuple[int, int], margin_px: float
) -> npt.NDArray[np.bool_]:
    """Pixels inside `polygon` farther than margin_px from its edge (cv2.fillPoly, cv2.erode)."""
    width, height = size
    mask = np.zeros((height, width), np.uint8)
    cv2.fillPoly(mask, [np.round(polygon).astype(np.int32)], 255)
    k = 2 * round(margin_px) + 1
    if k > 1:
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        return np.asarray(cv2.erode(mask, kernel, borderValue=255) > 0, dtype=np.bool_)
    return np.asarray(mask > 0, dtype=np.bool_)


def score(detection: Detection, annotation: Annotation, size: tuple[int, int]) -> Score:
    """How `detection` (of the annotated picture, `size` = (width, height)) fares."""
    width, height = size
    tolerance = TOLERANCE_QVGA_PX * width / QVGA_WIDTH
    hits = detection.lowest_px[detection.is_hit]
    hit_u = np.round(hits[:, 0]).astype(np.int64)
    scores = []
    for obstacle in annotation.obstacles:
        us = np.arange(int(np.ceil(obstacle.foot[0, 0])), int(np.floor(obstacle.foot[-1, 0])) + 1)
        us = us[(us >= 0) & (us < width)]
        foot_v = np.interp(us, obstacle.foot[:, 0], obstacle.foot[:, 1])
        errors = []
        for u, v in zip(us, foot_v, strict=True):
            near = np.abs(hit_u - u) <= 1
            if near.any():
                best = float(np.min(np.abs(hits[near, 1] - v)))
                if best <= tolerance:
                    errors.append(best)
        scores.append(
            ObstacleScore(
                obstacle.kind, len(us), len(errors), float(np.median(errors)) if errors else float("nan")
            )
        )
    inside_rows = np.clip(np.round(hits[:, 1]).astype(np.int64), 0, height - 1)
    inside_cols = np.clip(hit_u, 0, width - 1)
    open_floor = _inside(annotation.floor, size, tolerance)
    false_hits = int(open_floor[inside_rows, inside_cols].sum())
    shadow_hits = [int(_inside(s, size, 0.0)[inside_rows, inside_cols].sum()) for s in annotation.shadows]
    return Score(scores, len(detection.lowest_px), false_hits, shadow_hits)


@dataclass
class Evaluated:
    annotation: Annotation
    score: Score
    cpu_ms: float  # the detection's CPU time on this thread (time.thread_time)
    detection: Detection


def evaluate(annotation: Annotation, with_before: bool = True) -> Evaluated:
    """Runs the detector, as `cart2d camera detect` does, on the annotated picture (with the
    parallax cue against its earlier frame if it has one and `with_before`) and scores it."""
    camera = load_camera(annotation.camera)
    detector = ObstacleDetector(camera.calibration, camera.mount, camera.config)
    image = read_picture(annotation.image, camera)
    before = read_picture(annotation.before, camera) if with_before and annotation.before else None
    start = time.thread_time()
    detection = detect_pair(detector, ParallaxCue(camera.calibration), image, before)
    cpu_ms = 1000.0 * (time.thread_time() - start)
    size = (image.shape[1], image.shape[0])
    return Evaluated(annotation, score(detection, annotation, size), cpu_ms, detection)


def annotated(directory: Path, pictures: Path | None = None) -> list[Annotation]:
    """Every annotation (*.json but the camera files) in `directory`, by name; `pictures`: the
    folder of their pictures (None: beside them)."""
    return [
        Annotation.load(p, pictures)
        for p in sorted(directory.glob("*.json"))
        if not p.stem.endswith("_camera")
    ]
