"""A world file's "look" (issue 24): how the simulated world looks to the camera, checked here
so that `cart2d sim --world` and a mission refuse a bad one with a sentence before anything
starts. The simulator applies it (sim/src/look.cpp, the side channel's "look" message; the
fields and what they do: sim/README.md, "The look") and checks it again: these ranges are its."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

COLOUR = r"^#[0-9a-fA-F]{6}$"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class FloorSpec(_Strict):
    material: Literal["plain", "tiles", "planks", "carpet", "glossy"] = "plain"
    colour: str | None = Field(None, pattern=COLOUR)
    accent: str | None = Field(None, pattern=COLOUR, description="grout, seams, the carpet's pattern")
    size: float | None = Field(None, ge=0.02, le=5.0, description="tile, plank width, pattern (m)")
    length: float | None = Field(None, ge=0.1, le=10.0, description="plank length (m)")
    line: float | None = Field(None, ge=0.0, le=0.05, description="grout or seam width (m)")
    variation: float | None = Field(None, ge=0.0, le=0.5)
    gloss: float | None = Field(None, ge=0.0, le=1.0)


class WallsSpec(_Strict):
    colour: str | None = Field(None, pattern=COLOUR)
    skirting: float | None = Field(None, ge=0.0, le=0.5, description="skirting board height (m)")
    skirting_colour: str | None = Field(None, pattern=COLOUR)


class LightSpec(_Strict):
    x: float = Field(ge=-1e5, le=1e5, allow_inf_nan=False)
    y: float = Field(ge=-1e5, le=1e5, allow_inf_nan=False)
    z: float | None = Field(None, ge=0.5, le=20.0)
    power: float | None = Field(None, ge=0.0, le=5.0)
    radius: float | None = Field(None, ge=0.0, le=2.0)


class CameraLookSpec(_Strict):
    vignetting: float | None = Field(None, ge=0.0, le=0.9)
    uneven: float | None = Field(None, ge=0.0, le=0.5)
    auto_exposure: bool | None = None
    ae_target: float | None = Field(None, ge=10.0, le=245.0)
    ae_rate: float | None = Field(None, ge=0.01, le=1.0)
    shutter_ms: float | None = Field(None, ge=0.0, le=200.0)
    sensor_noise: bool | None = None


class LookSpec(_Strict):
    """Materials, lamps and the camera's effects; what it leaves out keeps today's look."""

    floor: FloorSpec | None = None
    walls: WallsSpec | None = None
    lights: list[LightSpec] | None = Field(None, max_length=8)
    ambient: float | None = Field(None, ge=0.0, le=2.0)
    cart_height: float | None = Field(None, ge=0.0, le=2.0)
    ceiling: str | None = Field(None, pattern=COLOUR)
    camera: CameraLookSpec | None = None

    def message(self) -> dict[str, Any]:
        """The side channel's "look": what the file gave, the simulator's defaults for the rest."""
        return self.model_dump(exclude_unset=True)
