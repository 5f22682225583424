"""The gateway's settings store: defaults, round trips, corrupt files, atomic saves."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from cart2d.store import GatewaySettings, MapSettings, NetworkSettings, Store, parse_settings


def test_missing_file_gives_the_seeds_map_and_loopback(tmp_path: Path) -> None:
    settings = Store(tmp_path).load()
    assert settings.network.host == "127.0.0.1" and settings.network.port == 8080
    assert (settings.map.cols, settings.map.rows, settings.map.step_m) == (10, 10, 0.2)
    assert settings.map.obstacles == [] and settings.token is None


def test_save_then_load_round_trips(tmp_path: Path) -> None:
    store = Store(tmp_path)
    saved = GatewaySettings(
        network=NetworkSettings(host="0.0.0.0", port=9000),
        map=MapSettings(cols=20, rows=12, step_m=0.1, obstacles=[(3, 4), (5, 6)]),
    )
    store.save(saved)
    assert store.load() == saved
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary file left behind


def test_corrupt_file_is_kept_aside_and_defaults_are_used(tmp_path: Path) -> None:
    store = Store(tmp_path)
    store.path.write_text('{"version": 1, "network": {"port": 99999}}')
    assert store.load() == GatewaySettings()
    assert len(list(tmp_path.glob("settings.json.corrupt-*"))) == 1


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        (b'{"network": {"port": 0}}', "network.port"),
        (b'{"map": {"step_m": "NaN"}}', "map.step_m"),
        (b'{"map": {"cols": 1}}', "map.cols"),
        (b'{"surprise": 1}', "surprise"),
        (b"not json", "invalid settings file"),
        (b"\xff\xfe", "invalid settings file"),
    ],
)
def test_imported_settings_are_validated(text: bytes, fragment: str) -> None:
    with pytest.raises(ValueError, match="invalid settings file") as info:
        parse_settings(text)
    assert fragment in str(info.value)


def test_token_is_generated_once_and_kept(tmp_path: Path) -> None:
    store = Store(tmp_path)
    first = store.ensure_token(store.load())
    assert first.token and len(first.token) >= 16
    assert store.ensure_token(store.load()).token == first.token


WRITER = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    from cart2d.store import GatewaySettings, MapSettings, Store
    store = Store(Path(sys.argv[1]))
    n = 0
    while True:
        n += 1
        # a big file (many obstacles) makes a torn write likely if saving were not atomic
        obstacles = [(n, i) for i in range(3000)]
        store.save(GatewaySettings(map=MapSettings(cols=1000, rows=1000, obstacles=obstacles)))
    """
)


def test_kill_9_during_saves_never_leaves_a_broken_file(tmp_path: Path) -> None:
    rng = random.Random(4)
    for _ in range(15):
        child = subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path)], env={**os.environ})
        deadline = time.monotonic() + 30
        while not Store(tmp_path).path.exists() and time.monotonic() < deadline:
            time.sleep(0.01)  # the first save (a slow machine takes a while to import)
        time.sleep(0.3 + rng.random() * 0.2)  # let it write for a while, then kill it anywhere
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
        loaded = Store(tmp_path).load()
        assert not list(tmp_path.glob("settings.json.corrupt-*")), "a save was torn"
        assert len(loaded.map.obstacles) == 3000  # a complete version, not defaults
        assert len({i for i, _ in loaded.map.obstacles}) == 1
        assert not list(tmp_path.glob(".settings.json.*.tmp"))  # the killed save's temporary is gone


def test_temporaries_of_killed_saves_are_removed_and_a_live_save_is_left_alone(tmp_path: Path) -> None:
    store = Store(tmp_path)
    store.save(GatewaySettings())
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    dead_pid = int(dead.stdout)  # that process has exited: its temporary is stale
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        stale = tmp_path / f".settings.json.{dead_pid}.tmp"
        stale.write_bytes(b"x" * 800_000)  # what a kill -9 mid-save leaves: up to 0.8 MB each
        old = tmp_path / f".settings.json.{live.pid}.old.tmp"  # not atomic_write's name: not touched
        old.write_bytes(b"x")
        saving = tmp_path / f".settings.json.{live.pid}.tmp"  # another process saving right now
        saving.write_bytes(b"x")
        reused = tmp_path / f".settings.json.{os.getppid()}.tmp"  # a live pid, but an hour old
        reused.write_bytes(b"x")
        os.utime(reused, (time.time() - 3600, time.time() - 3600))
        assert store.load() == GatewaySettings()
        assert not stale.exists() and not reused.exists()
        assert saving.exists() and old.exists()
    finally:
        live.kill()
        live.wait()
    store.load()
    assert not saving.exists()  # its writer is gone now
