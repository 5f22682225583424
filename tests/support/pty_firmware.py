"""A firmware fake on a pseudo-terminal the link opens as its serial port (no simulator): every
request is decoded; `answers` decides whether its reply goes out (the request is executed either
way, once per SEQ and CRC, as the firmware's duplicate memory has it). A telemetry frame goes
out every 40 ms, as the firmware's do: the line is alive. With `boot_s`, it is a Nano just reset
into its bootloader for that long first: silent, counting the bytes it is sent."""

from __future__ import annotations

import os
import select
import threading
import time
from collections.abc import Callable

from cart2d.link.protocol import Decoder, Packet, encode_reply, encode_telemetry
from cart2d.spec import load_spec

SPEC = load_spec()
TELEMETRY_S = 0.04


class FakeFirmware:
    def __init__(self, answers: Callable[[str, int], bool], boot_s: float = 0.0) -> None:
        self._master, self._slave = os.openpty()
        self.name = os.ttyname(self._slave)
        self.answers = answers
        self.received: list[str] = []  # every request's command name, retransmissions included
        self.executed: list[str] = []
        self.sent_while_booting = 0
        self._booted_at = time.monotonic() + boot_s
        self._last: tuple[int, int] | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        decoder = Decoder()
        next_frame = self._booted_at
        while not self._stop.is_set():
            booted = time.monotonic() >= self._booted_at
            if booted and time.monotonic() >= next_frame:
                next_frame += TELEMETRY_S
                os.write(self._master, encode_telemetry([0.0] * 16, 0))
            ready, _, _ = select.select([self._master], [], [], 0.005)
            if not ready:
                continue
            data = os.read(self._master, 4096)
            if not booted:
                self.sent_while_booting += len(data)
                continue
            for item in decoder.feed(data):
                if isinstance(item, Packet):
                    self._handle(item)

    def _handle(self, packet: Packet) -> None:
        name = SPEC.name_of(packet.body[0]).removeprefix("COMMAND_")
        self.received.append(name)
        if self._last != (packet.seq, packet.crc):
            self._last = (packet.seq, packet.crc)
            self.executed.append(name)
        if self.answers(name, len(self.received)):
            results = [0.0] * SPEC.commands[f"COMMAND_{name}"].result_count
            os.write(self._master, encode_reply(packet.seq, 0, packet.body[0], results))

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self._master)
        os.close(self._slave)
