"""`cart2d camera detect IMAGE... --camera FILE.json [--json]`: the obstacle detector on
pictures, with no cart. Per picture: the floor mask (PNG), the hits in pixels and on the floor
(base_link metres), and an overlay PNG, written to --out; a line each, or one JSON document.

FILE.json is either a calibration `cart2d camera calibrate` saved, or a nominal model of the
camera that took the pictures (docs/perception.md, "Trying the detector on your own pictures"):

    {"width_px": 320, "height_px": 240, "hfov_deg": 55, "height_m": 0.25, "pitch_deg": 32,
     "max_range_m": 1.25}

With --sequence the pictures are frames of one drive, in order: each after the first is also
compared with the one before it through the floor's homography fitted on the pictures (the
parallax cue, cart2d/perception/parallax.py; there is no odometry here)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.camera_file import detect_pair, load_camera, read_picture
from cart2d.perception.detection import Detection, ObstacleDetector, draw_overlay
from cart2d.perception.parallax import ParallaxCue


def result(
    path: Path, detection: Detection, out: Path, image: npt.NDArray[np.uint8], ms: float
) -> dict[str, Any]:
    stem = out / path.stem
    overlay, mask = stem.with_suffix(".overlay.png"), stem.with_suffix(".floor.png")
    cv2.imwrite(str(overlay), draw_overlay(image, detection))
    cv2.imwrite(str(mask), detection.floor_mask.astype(np.uint8) * 255)
    pixels = detection.lowest_px[detection.is_hit]
    return {
        "image": str(path),
        "floor_share": round(float(detection.floor_mask.mean()), 4),
        "hits_px": [[round(float(u), 1), round(float(v), 1)] for u, v in pixels],
        "hits_m": [[round(float(x), 4), round(float(y), 4)] for x, y in detection.hits],
        "support": [int(s) for s in detection.support],
        "floor_mask_png": str(mask),
        "overlay_png": str(overlay),
        "ms": round(ms, 2),
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("images", nargs="+", type=Path, metavar="IMAGE", help="pictures the camera took")
    parser.add_argument(
        "--camera",
        type=Path,
        required=True,
        metavar="FILE.json",
        help="a calibration, or a nominal camera model",
    )
    parser.add_argument(
        "--json", action="store_true", help="one JSON document on stdout instead of a line each"
    )
    parser.add_argument(
        "--out", type=Path, default=Path("."), help="where the overlay and floor-mask PNGs go (default: here)"
    )
    parser.add_argument(
        "--sequence",
        action="store_true",
        help="the pictures are frames of one drive, in order (the parallax cue)",
    )


def main_camera_detect(args: argparse.Namespace) -> int:
    try:
        camera = load_camera(args.camera)
        pictures = [read_picture(p, camera) for p in args.images]
        detector = ObstacleDetector(camera.calibration, camera.mount, camera.config)
    except ValueError as exc:
        print(f"cart2d camera detect: {exc}", file=sys.stderr)
        return 2
    if not args.out.is_dir():
        print(f"cart2d camera detect: {args.out}: no such directory", file=sys.stderr)
        return 2
    parallax = ParallaxCue(camera.calibration)
    results = []
    for k, (path, image) in enumerate(zip(args.images, pictures, strict=True)):
        if not args.sequence:
            detector.forget_floor()  # each picture learns its own floor
        before = pictures[k - 1] if args.sequence and k > 0 else None
        start = time.perf_counter()
        detection = detect_pair(detector, parallax, image, before)
        results.append(result(path, detection, args.out, image, 1000 * (time.perf_counter() - start)))
    if args.json:
        json.dump({"camera": str(args.camera), "pictures": results}, sys.stdout, indent=2)
        print()
    else:
        for r in results:
            print(
                f"{r['image']}: floor {100 * r['floor_share']:.0f} % of the picture, "
                f"{len(r['hits_px'])} hits, {r['ms']:.1f} ms -> {r['overlay_png']}"
            )
    return 0
