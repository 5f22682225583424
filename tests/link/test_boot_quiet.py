"""After opening a Nano's port (which resets it into its bootloader) the link sends nothing until
the firmware speaks: Optiboot takes the first second's bytes as STK500 commands, and a request's
bytes there held it in a page write while the requests kept coming (fresh run 9: "no reply to
COMMAND_SET_POSE after 5 tries" right after an open). Against a pseudo-terminal whose "bootloader"
is silent for a while and counts what it is sent meanwhile."""

from __future__ import annotations

import os
import select
import threading
import time

from cart2d.link import Link
from cart2d.link.protocol import Decoder, Packet, encode_reply, encode_telemetry
from cart2d.spec import load_spec

SPEC = load_spec()
BOOT_S = 0.5


class BootingNano:
    """Silent for BOOT_S (counting the bytes it is sent), then the firmware: telemetry every
    40 ms, and a reply to every request."""

    def __init__(self) -> None:
        self._master, self._slave = os.openpty()
        self.name = os.ttyname(self._slave)
        self.sent_while_booting = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        booted_at = time.monotonic() + BOOT_S
        decoder = Decoder()
        next_frame = booted_at
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.005)
            data = os.read(self._master, 4096) if ready else b""
            now = time.monotonic()
            if now < booted_at:
                self.sent_while_booting += len(data)
                continue
            if now >= next_frame:
                next_frame += 0.04
                os.write(self._master, encode_telemetry([0.0] * 16, 0))
            for item in decoder.feed(data):
                if isinstance(item, Packet):
                    results = [0.0] * SPEC.commands[SPEC.name_of(item.body[0])].result_count
                    os.write(self._master, encode_reply(item.seq, 0, item.body[0], results))

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self._master)
        os.close(self._slave)


def test_nothing_is_sent_to_a_booting_nano_and_the_first_request_waits_for_it() -> None:
    nano = BootingNano()
    try:
        with Link(nano.name, timeout_s=0.1).open() as link:
            reply = link.request("STATUS")
    finally:
        nano.close()
    assert nano.sent_while_booting == 0
    assert reply.ok
