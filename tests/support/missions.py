"""A mission in the 4 m arena with a box the map does not show, beyond the camera's range at
the start."""

from __future__ import annotations

import json
from typing import Any

from cart2d.tools.missions.spec import MissionSpec

BOX: dict[str, Any] = {"x": 2.4, "y": 2.0, "sx": 0.2, "sy": 0.6, "height": 0.3, "colour": "#3050c0"}


def mission(**extra: Any) -> MissionSpec:
    # In the 4 m arena the box stands 2 m straight ahead on the way to the goal, beyond the
    # camera's range (1.25 m) and so beyond the look before driving off: the first plan runs
    # straight through it, and only driving towards it shows it.
    body = {
        "grid": {"cols": 41, "rows": 41, "step": 0.1},
        "start": [0.3, 2.0, 0.0],
        "goals": [[3.7, 2.0]],
        "world": {"boxes": [BOX]},
        "timeout_s": 60.0,
        **extra,
    }
    return MissionSpec.model_validate_json(json.dumps(body))
