"""The API's routes, one module a resource; create_app includes them in this order (/ws after
the routes that the older modules add to the app, the panel's files last)."""

from cart2d.server.routes import firmware, live, map, motion, pose, status

ROUTERS = (status.router, map.router, motion.router, firmware.router, pose.router)
LIVE_ROUTER = live.router

__all__ = ["LIVE_ROUTER", "ROUTERS"]
