"""After opening a Nano's port (which resets it into its bootloader) the link sends nothing until
the firmware speaks: Optiboot takes the first second's bytes as STK500 commands, and a request's
bytes there held it in a page write while the requests kept coming (fresh run 9: "no reply to
COMMAND_SET_POSE after 5 tries" right after an open). Against a pseudo-terminal whose "bootloader"
is silent for a while and counts what it is sent meanwhile."""

from __future__ import annotations

from cart2d.link import Link
from tests.support.pty_firmware import FakeFirmware

BOOT_S = 0.5


def test_nothing_is_sent_to_a_booting_nano_and_the_first_request_waits_for_it() -> None:
    nano = FakeFirmware(lambda name, n: True, boot_s=BOOT_S)
    try:
        with Link(nano.name, timeout_s=0.1).open() as link:
            reply = link.request("STATUS")
    finally:
        nano.close()
    assert nano.sent_while_booting == 0
    assert reply.ok
