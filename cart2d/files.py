"""Reading a file a user named (a mission, a map's YAML and image, a world): a regular file only,
and no more than a limit. `"map": "/dev/zero"` read until MemoryError, and opening a FIFO
blocks until something writes to it."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path


def read_regular(path: Path, limit: int) -> bytes:
    """The bytes of the regular file at `path`; OSError (strerror a phrase) for a folder
    (IsADirectoryError), a device, a FIFO or a socket, or a file over `limit` bytes."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO opens at once instead of waiting
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(errno.EISDIR, "it is a folder", str(path))
        if not stat.S_ISREG(mode):
            raise OSError(errno.EINVAL, "it is not a regular file (a device, a pipe or a socket)", str(path))
        with os.fdopen(fd, "rb", closefd=False) as file:
            data = file.read(limit + 1)  # the size may change as it is read: count what comes
    finally:
        os.close(fd)
    if len(data) > limit:
        raise OSError(errno.EFBIG, f"it is over {limit} bytes", str(path))
    return data
