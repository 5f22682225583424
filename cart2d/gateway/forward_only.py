"""While the gateway sees, the cart drives forwards only (issue 14).

The camera (an ESP32-CAM) looks forwards: a cart that backs up to a waypoint behind it (the
seed's polar law) drives where it has never looked, and on the unknown-arena benchmark 3 of 4 box
contacts came that way, 0.9-2 m backwards into boxes. The firmware setting `reverse_allowed`
(config/robot.toml) makes it turn on the spot to face such a waypoint instead. The gateway
writes 0 while it sees and puts back the value it replaced once it no longer does.

It does so whenever the camera comes or goes, and again before every route it sends: a restart
of the MCU loads the saved settings (reversing allowed, by default), and the next route must not
be driven backwards because of it. The value is written with PARAM_SET, in RAM only: a SAVE while
seeing keeps 0 in the EEPROM (the settings show 0 then, as the firmware drives).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

from cart2d.link import CommandRefused, Link, LinkError, firmware
from cart2d.params import setting_id

REVERSE_ALLOWED = setting_id("reverse_allowed")


@dataclass
class ReverseGuard:
    """What the gateway replaced of the user's `reverse_allowed`, to put it back."""

    users_value: float | None = None  # None: the firmware holds the user's value

    def apply(self, link: Link, seeing: bool) -> None:
        """reverse_allowed = 0 in the firmware while `seeing`, the user's value otherwise.
        LinkError / CommandRefused if the firmware cannot be read or written."""
        if not seeing and self.users_value is None:
            return  # nothing to do: no round trip on the link without a camera
        current = firmware.read_setting(link, REVERSE_ALLOWED)
        if seeing:
            if current != 0.0:
                firmware.write_setting(link, REVERSE_ALLOWED, 0.0)
                self.users_value = current  # the user's, or the saved one a restart loaded
        else:
            if current == 0.0:
                firmware.write_setting(link, REVERSE_ALLOWED, float(self.users_value or 0.0))
            self.users_value = None

    def try_apply(self, link: Link, seeing: bool) -> None:
        """apply(), when the firmware answers (a camera set before the link is up, a link lost):
        the next route applies it for certain."""
        if not link.connected.is_set():
            return  # no waiting for retries of a request that cannot be answered
        with contextlib.suppress(LinkError, CommandRefused):
            self.apply(link, seeing)
