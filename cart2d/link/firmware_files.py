"""Firmware files for updates: the check of an uploaded Intel HEX, and the files kept by content.

The check is the simulator's own reader (`cart2d-sim --check-firmware FILE`, sim/src/
firmware_file.cpp): strict records, exactly what simavr reads, a program below the Nano's
bootloader that starts with the ATmega328P's vector table. One parser for the simulator and the
real cart, so a file the gateway takes is a file the simulator loads, and the other way round.

Every file flashed is kept under its content's hash, and the last one that answered the protocol
is remembered (`good`): a rollback returns to those very bytes, never to a path that a later
upload has overwritten.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import subprocess
import tempfile
from pathlib import Path

from cart2d.link.built import default_binary

CHECK_TIMEOUT_S = 10.0
KEEP_FILES = 8  # firmware files kept besides the good one (the oldest go first)


class CheckerMissing(RuntimeError):
    """The firmware checker (cart2d-sim) is not built."""


def check_hex(data: bytes, checker: Path | None = None) -> int:
    """The number of program bytes in an Intel HEX upload; ValueError with the reason in a
    sentence if the simulator's reader refuses it (the same refusal for the real cart)."""
    binary = checker or default_binary()
    if not binary.exists():
        raise CheckerMissing(f"the firmware checker {binary} is not built (make sim)")
    with tempfile.TemporaryDirectory(prefix="cart2d-check-") as tmp:
        path = Path(tmp) / "upload.hex"
        path.write_bytes(data)
        try:
            done = subprocess.run(
                [str(binary), "--check-firmware", str(path)],
                capture_output=True,
                text=True,
                timeout=CHECK_TIMEOUT_S,
                check=False,
            )
        except subprocess.TimeoutExpired as exc:
            raise ValueError(f"the firmware check took over {CHECK_TIMEOUT_S:g} s") from exc
    try:
        verdict = json.loads(done.stdout.splitlines()[0])
    except (IndexError, ValueError) as exc:
        raise CheckerMissing(f"the firmware checker {binary} gave no verdict ({done.returncode})") from exc
    if not verdict.get("ok"):
        raise ValueError(str(verdict.get("error", "refused")))
    return int(verdict["bytes"])


class FirmwareArchive:
    """Firmware files by content (`<sha256 prefix><suffix>`) and which one last answered."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory

    def keep(self, data: bytes, suffix: str) -> Path:
        """The archived file with these bytes (written once, atomically)."""
        self.directory.mkdir(parents=True, exist_ok=True)
        path = self.directory / f"{hashlib.sha256(data).hexdigest()[:16]}{suffix}"
        if not path.exists() or path.read_bytes() != data:
            self._write(path, data)
        self._prune()
        return path

    def keep_file(self, source: Path) -> Path:
        return self.keep(source.read_bytes(), source.suffix)

    def mark_good(self, path: Path) -> None:
        """`path` (an archived file) answered the protocol: the one to roll back to."""
        if path.parent == self.directory and path.exists():
            self._write(self.directory / "good", path.name.encode())

    def good(self) -> Path | None:
        """The last archived file that answered, if it is still there."""
        with contextlib.suppress(OSError):
            name = (self.directory / "good").read_text().strip()
            path = self.directory / name
            if name and "/" not in name and path.is_file():
                return path
        return None

    def _write(self, path: Path, data: bytes) -> None:
        handle, tmp = tempfile.mkstemp(dir=self.directory, prefix=".tmp-")
        try:
            with os.fdopen(handle, "wb") as out:
                out.write(data)
            os.replace(tmp, path)
        finally:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)

    def _prune(self) -> None:
        good = self.good()
        files = [p for p in self.directory.iterdir() if p.is_file() and p.name != "good" and p != good]
        files = [p for p in files if not p.name.startswith(".tmp-")]
        for old in sorted(files, key=lambda p: p.stat().st_mtime)[:-KEEP_FILES]:
            with contextlib.suppress(OSError):
                old.unlink()


def copy_into(archive: FirmwareArchive, source: Path) -> Path | None:
    """`source` kept by content in the archive; None if it cannot be read."""
    try:
        return archive.keep_file(source)
    except OSError:
        return None
