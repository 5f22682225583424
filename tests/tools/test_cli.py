"""The command line as a new user meets it: options that apply to one run, bad values in one
sentence (no traceback), an address or a port it cannot listen on, a serial port that is not
there, --version. Each `cart2d` runs in a process of its own with its own CART2D_HOME."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from cart2d import __version__
from cart2d.server.addresses import panel_urls
from cart2d.server.guards import machine_addresses
from cart2d.spec import load_spec
from tests.support.cli import cart2d, fake_ports_and_serve, one_sentence, running_cart2d
from tests.support.sockets import free_port
from tests.support.waiting import wait_for, wait_serving

NOT_HERE = "198.51.100.77"  # TEST-NET-2 (RFC 5737): an address no machine running the tests has


@pytest.fixture
def listening_elsewhere() -> Iterator[int]:
    """A port another program listens on."""
    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        yield other.getsockname()[1]


def test_version_names_the_package_and_the_protocol(tmp_path: Path) -> None:
    done = cart2d(tmp_path, "--version")
    assert done.returncode == 0
    assert f"cart2d {__version__}" in done.stdout
    assert f"firmware protocol {load_spec().version}" in done.stdout


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["sim", "--port", "99999"], "argument --port: '99999' is not a port"),
        (["sim", "--port", "http"], "argument --port: 'http' is not a port"),
        (["sim", "--speed", "0"], "argument --speed: '0' is not a speed"),
        (["sim", "--speed", "abc"], "argument --speed: 'abc' is not a speed"),
        (["sim", "--seed", "-1"], "argument --seed: '-1' is not a seed"),
        (["sim", "--host", "evil host"], "argument --host: 'evil host'"),
        (["mission", "m.json", "--speed", "nan"], "argument --speed: 'nan' is not a speed"),
        (["calibrate", "--sim", "--speed", "-2"], "argument --speed: '-2' is not a speed"),
        (
            ["serve", "--serial", "x", "--camera", "http://cam/stream"],
            "argument --camera: the camera's URL is",
        ),
        (["sim", "--camera", "rtsp://cam"], "argument --camera: the camera's URL must be http://"),
        (["serve", "--serial", "x", "--camera-stream", "cam:81"], "argument --camera-stream: the camera's"),
    ],
)
def test_bad_option_values_are_one_sentence(tmp_path: Path, args: list[str], words: str) -> None:
    done = cart2d(tmp_path, *args)
    assert done.returncode == 2
    line = one_sentence(done.stderr)
    assert line.startswith(f"cart2d {args[0]}: error: {words}"), line
    assert "cart2d-sim" not in done.stderr  # not the simulator's usage text
    assert not (tmp_path / "settings.json").exists()


def test_a_port_in_use_is_one_sentence_and_no_url(tmp_path: Path, listening_elsewhere: int) -> None:
    done = cart2d(tmp_path, "sim", "--host", "127.0.0.1", "--port", str(listening_elsewhere))
    assert done.returncode == 1
    line = one_sentence(done.stderr)
    assert f"127.0.0.1 port {listening_elsewhere} is in use" in line
    assert "http://" not in done.stdout  # no panel address that is another program's
    assert not (tmp_path / "settings.json").exists()


def listening_after_a_free_port() -> socket.socket:
    """A socket another program listens on, at a port P whose P - 1 is free (bound for a moment)."""
    while True:
        other = socket.socket()
        other.bind(("127.0.0.1", 0))
        other.listen()
        with socket.socket() as before:
            try:
                before.bind(("127.0.0.1", other.getsockname()[1] - 1))
                return other
            except OSError:
                other.close()


@pytest.mark.parametrize("stream", [False, True])
def test_a_camera_port_in_use_is_one_sentence_before_anything_starts(tmp_path: Path, stream: bool) -> None:
    # once uvicorn's "[Errno 98] error while attempting to bind", and the cart ran without camera
    with listening_after_a_free_port() as other:
        in_use = other.getsockname()[1]
        camera_port = in_use - 1 if stream else in_use  # the stream's is the next port
        done = cart2d(tmp_path, "sim", "--port", str(free_port()), "--camera-port", str(camera_port))
    assert done.returncode == 1
    line = one_sentence(done.stderr)
    assert line.startswith("cart2d sim: the simulated camera cannot listen: ") and "--camera-port" in line
    assert f"127.0.0.1 port {in_use} is in use" in line
    assert "Errno" not in line and "simulator running" not in done.stdout and "http://" not in done.stdout
    assert not (tmp_path / "sim-eeprom.bin").exists()  # the simulator never started


def test_the_camera_port_leaves_room_for_its_stream(tmp_path: Path) -> None:
    done = cart2d(tmp_path, "sim", "--camera-port", "65535")
    assert done.returncode == 2
    assert "65535 leaves no port for the camera's stream" in one_sentence(done.stderr)


def test_an_address_this_machine_does_not_have_is_one_sentence_and_not_saved(tmp_path: Path) -> None:
    done = cart2d(tmp_path, "sim", "--host", NOT_HERE, "--port", str(free_port()))
    assert done.returncode == 1
    assert f"{NOT_HERE} is not an address of this machine" in one_sentence(done.stderr)
    assert "http://" not in done.stdout
    assert not (tmp_path / "settings.json").exists()  # neither the address nor a token kept


def test_a_saved_address_this_machine_does_not_have_names_the_file(tmp_path: Path) -> None:
    (tmp_path / "settings.json").write_text(json.dumps({"network": {"host": NOT_HERE, "port": 8080}}))
    done = cart2d(tmp_path, "sim")
    assert done.returncode == 1
    line = one_sentence(done.stderr)
    assert NOT_HERE in line and str(tmp_path / "settings.json") in line and "--host" in line


def test_host_and_port_given_apply_to_that_run_only(tmp_path: Path) -> None:
    """`cart2d sim --host 0.0.0.0 --port P --fault ...` listens there with that fault, says the
    token is needed from this machine too, and leaves the saved address as it was (only the
    token is kept)."""
    port = free_port()
    run = ["sim", "--host", "0.0.0.0", "--port", str(port), "--fault", "enc_slip_l=0.05", "--no-camera"]
    with running_cart2d(tmp_path, *run) as gateway:
        wait_serving(port)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/sim/faults", timeout=5) as answer:
            assert json.load(answer)["faults"]["enc_slip_l"] == 0.05  # --fault applies from the start
        out = gateway.stop()
    saved = json.loads((tmp_path / "settings.json").read_text())
    assert saved["network"] == {"host": "127.0.0.1", "port": 8080}
    assert saved["token"]
    # this machine's address first, then every other IPv4 address of its interfaces (issue 22:
    # only http://127.0.0.1 was printed, which no other machine can open)
    others = [a for a in machine_addresses() if "." in a and not a.startswith("127.")]
    assert f"cart2d panel: http://127.0.0.1:{port}/" in out
    assert all(f"http://{a}:{port}/" in out for a in others), out
    assert out.count("http://") == 1 + len(others)
    (token_line,) = [line for line in out.splitlines() if saved["token"] in line]
    assert "off this machine" not in token_line and "from this machine too" in token_line


def test_serve_with_a_serial_port_that_is_not_there_lists_those_that_are(tmp_path: Path) -> None:
    done = fake_ports_and_serve(tmp_path, "/dev/ttyUSB9")
    assert done.returncode == 1
    line = one_sentence(done.stderr)
    assert "there is no serial port /dev/ttyUSB9" in line
    assert "/dev/ttyACM3 (USB2.0-Serial), /dev/ttyUSB7 (FT232R USB UART)" in line
    assert "http://" not in done.stdout


def test_serve_with_a_file_that_is_no_serial_port_says_why(tmp_path: Path) -> None:
    not_a_tty = tmp_path / "notes.txt"
    not_a_tty.write_text("not a serial port\n")
    done = fake_ports_and_serve(tmp_path, str(not_a_tty))
    assert done.returncode == 1
    line = one_sentence(done.stderr)
    assert f"cannot open {not_a_tty}" in line and "/dev/ttyUSB7" in line


def test_the_panel_is_announced_at_every_address_other_machines_can_open() -> None:
    here = ["127.0.0.1", "::1", "192.168.1.20", "10.0.0.5", "fe80::1", "2001:db8::7", "169.254.3.4"]
    assert panel_urls("0.0.0.0", 8080, here) == [
        "http://127.0.0.1:8080/",
        "http://10.0.0.5:8080/",
        "http://192.168.1.20:8080/",
    ]
    assert panel_urls("::", 8080, here)[-1] == "http://[2001:db8::7]:8080/"  # no link-local ones
    assert panel_urls("192.168.1.20", 8081) == ["http://192.168.1.20:8081/"]
    assert panel_urls("::1", 8080) == ["http://[::1]:8080/"]


def test_any_loopback_address_needs_no_token_as_the_readme_says(tmp_path: Path) -> None:
    """127.0.0.2 is loopback: only this machine reaches it, so no token, like 127.0.0.1 (issue
    22: the README said every address but 127.0.0.1 needed one)."""
    port = free_port()
    run = ["sim", "--host", "127.0.0.2", "--port", str(port), "--no-camera"]
    with running_cart2d(tmp_path, *run) as gateway:
        wait_for(lambda: _answers(f"http://127.0.0.2:{port}/api/status"), 60, 0.2)
        change = urllib.request.Request(
            f"http://127.0.0.2:{port}/api/map/obstacle",
            data=b'{"x": 1.0, "y": 1.0}',
            headers={"Content-Type": "application/json"},
            method="PUT",
        )
        with urllib.request.urlopen(change, timeout=10) as answer:  # no token
            assert answer.status == 200
        out = gateway.stop(signal.SIGINT)
    assert f"cart2d panel: http://127.0.0.2:{port}/" in out and "access token" not in out
    assert not json.loads((tmp_path / "settings.json").read_text()).get("token")
    readme = (Path(__file__).parents[2] / "README.md").read_text()
    security = readme[readme.index("- **Security**") :].split("\n- **", 1)[0]
    assert "127.0.0.0/8" in security and "need no token" in security, security


def _answers(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=2) as answer:
            return bool(json.load(answer).get("firmware"))
    except OSError:
        return False


def start_and_interrupt(home: Path, when: str, then_s: float) -> tuple[int | None, str]:
    """`cart2d sim` (the installed command) in a session of its own, Ctrl-C as a terminal sends it
    (SIGINT to the process group: the simulator too) `then_s` after it printed a line with `when`
    in it ("" at once); its exit status (None: still running 30 s later) and its output."""
    command = Path(sys.executable).with_name("cart2d")
    process = subprocess.Popen(
        [str(command), "sim", "--port", str(free_port()), "--no-camera"],
        env={**os.environ, "CART2D_HOME": str(home)},
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    assert process.stdout is not None
    before = ""
    for line in process.stdout if when else ():
        before += line
        if when in line:
            break
    time.sleep(then_s)
    os.killpg(process.pid, signal.SIGINT)
    try:
        out, _ = process.communicate(timeout=30)
        return process.returncode, before + out
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        return None, before + process.communicate()[0]


@pytest.mark.parametrize(
    ("when", "then_s"),
    [("", 0.3), ("host opened the serial port", 0.3), ("cart2d panel:", 0.0)],
    # while Python imports the command's modules; while the gateway waits for the firmware's
    # first answer (the Nano's bootloader keeps it 0.5 s at least); while it serves
    ids=["importing", "connecting", "serving"],
)
def test_ctrl_c_at_any_moment_of_the_start_ends_quietly(tmp_path: Path, when: str, then_s: float) -> None:
    """Issue 22: a Ctrl-C while the command's modules were still being imported (seconds on a busy
    machine) printed a traceback of the import machinery; one while the gateway waited for the
    firmware's first answer, a RuntimeError from its monitor thread that had not started."""
    status, out = start_and_interrupt(tmp_path, when, then_s)
    assert status == 0 and "Traceback" not in out and "KeyboardInterrupt" not in out, out
