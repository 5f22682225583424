"""What the floor looks like, in terms a shadow does not change (the appearance cue).

A shadow on the floor (or the shade under a desk) dims the light the floor gets; it hardly
changes the floor's colour. So the model keeps two things apart (Finlayson's chromaticity; Ulrich
& Nourbakhsh's histogram back-projection for the rest):

- chromaticity, r = R / (R + G + B) and g = G / (R + G + B), unchanged when all three channels
  scale together: a 2-D histogram (cv2.calcHist), back-projected on every pixel
  (cv2.calcBackProject), each bin widened to its neighbours;
- brightness, (R + G + B) / 3, in a 1-D histogram: a pixel is bright enough for floor when some
  floor brightness b seen in the patch has shadow_ratio * b <= its brightness <= glare * b. The
  rule is a 256-entry table applied with cv2.LUT.

What a colour can never tell apart (an off-white wall behind an off-white floor, a grey leg on a
grey floor) it does not try to: the parallax and the boundary cues decide those.

The model learns from the patch of floor just in front of the cart, and only from the patch's
pixels that no cue flags (detection.py): at the first frame everything in the patch, later a
blend (learn_rate) that forgets in about 1 / learn_rate frames whatever the first frame had in
its patch that was not floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

BoolImage = npt.NDArray[np.bool_]
U8Image = npt.NDArray[np.uint8]

CHROMA_BINS = 32
CHROMA_LOW, CHROMA_HIGH = 0.15, 0.55  # r and g of indoor colours; outside, the first or last bin
BRIGHTNESS_BINS = 64


@dataclass(frozen=True)
class FloorModelConfig:
    shadow_ratio: float = 0.45  # a floor in shade keeps at least this much of its brightness
    glare: float = 1.15  # ... and a lit or glossy patch at most this much more
    chroma_likelihood: float = 0.06  # back-projection (of the widened histogram's peak) for floor
    brightness_share: float = 0.004  # a brightness bin with less of the patch is noise
    learn_rate: float = 0.05


def chromaticity(bgr: U8Image) -> tuple[U8Image, U8Image]:
    """(chroma, brightness): chroma H x W x 2 (r and g scaled from CHROMA_LOW..CHROMA_HIGH to
    0..255), brightness H x W, both uint8."""
    total = cv2.transform(bgr.astype(np.float32), np.ones((1, 3), np.float32))
    total = np.maximum(total, 1.0)
    scale = 255.0 / (CHROMA_HIGH - CHROMA_LOW)
    r = cv2.divide(bgr[..., 2].astype(np.float32), total)
    g = cv2.divide(bgr[..., 1].astype(np.float32), total)
    chroma = cv2.merge([r, g])
    chroma = cv2.convertScaleAbs(chroma, alpha=scale, beta=-CHROMA_LOW * scale)
    brightness = cv2.convertScaleAbs(total, alpha=1.0 / 3.0)
    return np.asarray(chroma, dtype=np.uint8), np.asarray(brightness, dtype=np.uint8)


class FloorModel:
    def __init__(self, config: FloorModelConfig | None = None) -> None:
        self.config = config or FloorModelConfig()
        self.chroma_hist: npt.NDArray[np.float32] | None = None
        self.brightness_hist: npt.NDArray[np.float32] | None = None
        self.brightness_ok = np.zeros(256, np.uint8)

    @property
    def learnt(self) -> bool:
        return self.chroma_hist is not None

    def learn(self, chroma: U8Image, brightness: U8Image, mask: BoolImage, rate: float | None = None) -> None:
        """Learns from the pixels under `mask`: all of it the first time (or with rate 1), else
        blended in at `rate` (the config's learn_rate by default)."""
        m = mask.astype(np.uint8)
        if not m.any():
            return
        counts = np.asarray(cv2.calcHist([chroma], [0, 1], m, [CHROMA_BINS, CHROMA_BINS], [0, 256, 0, 256]))
        levels = np.asarray(cv2.calcHist([brightness], [0], m, [BRIGHTNESS_BINS], [0, 256])).ravel()
        chroma_hist = np.asarray(counts / max(float(counts.sum()), 1.0), dtype=np.float32)
        brightness_hist = np.asarray(levels / max(float(levels.sum()), 1.0), dtype=np.float32)
        a = 1.0 if self.chroma_hist is None else (self.config.learn_rate if rate is None else rate)
        if self.chroma_hist is None or self.brightness_hist is None:
            self.chroma_hist, self.brightness_hist = chroma_hist, brightness_hist
        else:
            self.chroma_hist = np.asarray((1.0 - a) * self.chroma_hist + a * chroma_hist, dtype=np.float32)
            self.brightness_hist = np.asarray(
                (1.0 - a) * self.brightness_hist + a * brightness_hist, dtype=np.float32
            )
        self._brightness_table()

    def _brightness_table(self) -> None:
        """brightness_ok[v] = 255 if some floor brightness b (a bin's centre, with enough of the
        patch) has shadow_ratio * b <= v <= glare * b."""
        assert self.brightness_hist is not None
        k = self.config
        step = 256 / BRIGHTNESS_BINS
        centres = (np.nonzero(self.brightness_hist >= k.brightness_share)[0] + 0.5) * step
        values = np.arange(256, dtype=np.float64)[:, None]
        low = k.shadow_ratio * (centres - step / 2)
        high = k.glare * (centres + step / 2) + 4.0
        ok = ((values >= low[None, :]) & (values <= high[None, :])).any(axis=1)
        self.brightness_ok = np.where(ok, 255, 0).astype(np.uint8)

    def floor_like(self, chroma: U8Image, brightness: U8Image) -> BoolImage:
        """True where a pixel's chromaticity and brightness are the floor's."""
        if self.chroma_hist is None:
            raise RuntimeError("the floor model has learnt nothing yet")
        wide = cv2.dilate(self.chroma_hist, np.ones((3, 3), np.uint8))  # each bin as its neighbours
        peak = max(float(wide.max()), 1e-12)
        scaled = np.asarray(np.minimum(wide * (255.0 / peak), 255.0), dtype=np.float32)
        likely = cv2.calcBackProject([chroma], [0, 1], scaled, [0, 256, 0, 256], 1)
        chroma_ok = likely >= self.config.chroma_likelihood * 255.0
        bright_ok = cv2.LUT(brightness, self.brightness_ok) > 0
        return np.asarray(chroma_ok & bright_ok, dtype=np.bool_)
