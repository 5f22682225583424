"""The gateway: what the seed's ESP32 did, as one object the HTTP API and the command line use
(core), and what it keeps about missions, the pose and restarts (state)."""

from cart2d.gateway.core import Gateway
from cart2d.gateway.state import Mission, PathTooLong, PoseOutsideArena, PoseUntrusted, Refused, ResetReport

__all__ = ["Gateway", "Mission", "PathTooLong", "PoseOutsideArena", "PoseUntrusted", "Refused", "ResetReport"]
