"""Talking to the firmware: the wire format (protocol), the serial transport with its retries and
reader thread (transport), what the gateway asks of the firmware in words (firmware), and
firmware updates (flashing). The transport's names are the package's: `from cart2d.link import
Link`."""

from cart2d.link.transport import (
    CommandRefused,
    Link,
    LinkDown,
    LinkError,
    LinkTimeout,
    MotionCancelled,
    Priority,
)

__all__ = ["CommandRefused", "Link", "LinkDown", "LinkError", "LinkTimeout", "MotionCancelled", "Priority"]
