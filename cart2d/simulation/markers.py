"""The fiducial markers in the simulated world (sim/src/marker_render.hpp): each marker of a
markers file sent with OpenCV's own bitmap of its id, so that the detector finds real tag
patterns in the simulated camera's picture."""

from __future__ import annotations

from typing import Any, Protocol

from cart2d.localisation.markers import BITMAP_CELLS, Marker, MarkerMap, bitmap


class Controls(Protocol):
    def control(self, kind: str, **members: Any) -> dict[str, Any]: ...


def marker_message(marker: Marker) -> dict[str, Any]:
    r = marker.rotation()
    bits = "".join("1" if cell else "0" for cell in bitmap(marker.id).ravel())
    return {
        "id": marker.id,
        "size_m": marker.size_m,
        "centre": marker.centre().tolist(),
        "x_axis": r[:, 0].tolist(),
        "y_axis": r[:, 1].tolist(),
        "cells": BITMAP_CELLS,
        "bits": bits,
    }


def place_markers(sim: Controls, markers: MarkerMap) -> None:
    """The simulator's camera sees these markers from now on (none: MarkerMap())."""
    sim.control("markers", markers=[marker_message(m) for m in markers.markers])
