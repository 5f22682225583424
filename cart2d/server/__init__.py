"""The gateway's HTTP and WebSocket API: the application and its routes (app), the request and
error models (models), the panel's files (panel)."""

from cart2d.server.app import create_app
from cart2d.server.guards import is_loopback
from cart2d.server.models import MAX_BODY_BYTES

__all__ = ["MAX_BODY_BYTES", "create_app", "is_loopback"]
