"""What the gateway may be given besides its Link, all optional (ArduPilot keeps SITL behind its
HAL: the gateway never asks whether it is simulated). The simulation package
(cart2d/simulation/wiring.py) provides each for `cart2d sim` and `cart2d mission`; a real cart
has none of them:

- a source of ground truth: the cart's clock (the simulator's time) and the truth messages
  handed to viewers as they come;
- a simulated world whose walls follow the map, and whose boxes a recording starts with;
- the MCU's reset button (the restart watch presses it for a soft reset, restarts.py);
- the bootloader port the flasher reaches the MCU through (cart2d/link/bootloader.py).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from cart2d.maps.world import World


class GroundTruth(Protocol):
    def time_s(self) -> float | None:
        """The cart's clock, s: the time of the latest truth message (None before the first)."""
        ...

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Calls listener(message) with every truth message ({"type": "truth", ...})."""
        ...


class SimulatedWorld(Protocol):
    def follow_walls(self, walls: Callable[[], World]) -> None:
        """Makes the world's walls `walls()` (the map's), now and at every restart; its boxes
        stay. A world that does not answer keeps them for its next start."""
        ...

    def boxes_view(self) -> dict[str, Any] | None:
        """The boxes standing now, as the /ws `sim_world` message has them; None if it does not
        answer."""
        ...


ResetButton = Callable[[], None]  # presses the MCU's reset button; LinkError if it cannot
