"""The simulator's faults from the command line and the API (cart2d sim --fault, GET/PUT
/api/sim/faults), checked against the simulator itself: cart2d/simulation/faults.py's table is the
simulator's (every key, both ends of every range), and a fault set through the gateway changes
what the simulated encoders count."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cart2d.gateway import Gateway
from cart2d.link import Link
from cart2d.simulation import faults as fault_table
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from cart2d.store import Store
from tests.support.cli import cart2d
from tests.support.server import Rig
from tests.support.sim import start_sim
from tests.support.waiting import wait_for


def test_the_fault_table_is_the_simulators(sim: Simulator) -> None:
    assert set(sim.faults()) == {f.name for f in fault_table.FAULTS}
    assert sim.faults() == fault_table.defaults()
    for fault in fault_table.FAULTS:
        for value in (fault.low, fault.high):
            sim.control("faults", clear=True, **{fault.name: value})  # accepted: no SimulatorError
            assert fault_table.value_problem(fault.name, value) is None
        step = 1.0 if fault.whole else 1e-6 * max(1.0, fault.high - fault.low)
        for value in (fault.low - step, fault.high + step):
            with pytest.raises(SimulatorError):
                sim.control("faults", clear=True, **{fault.name: value})
            assert fault_table.value_problem(fault.name, value) is not None
        if fault.whole:
            with pytest.raises(SimulatorError):
                sim.control("faults", **{fault.name: (fault.low + fault.high) / 2})
            assert fault_table.value_problem(fault.name, (fault.low + fault.high) / 2) is not None


@pytest.mark.parametrize(
    ("options", "lines"),
    [
        (
            ["--fault", "enc_slip_l=2"],
            ["--fault enc_slip_l=2: fault enc_slip_l takes a number from 0 to 0.99"],
        ),
        (["--fault", "warp=1"], ["--fault warp=1: unknown fault 'warp' (known: enc_radius_scale_l, "]),
        (["--fault", "enc_noise_hz"], ["--fault enc_noise_hz: 'enc_noise_hz' is not KEY=VALUE"]),
        (
            ["--fault", "enc_noise_hz=lots"],
            ["--fault enc_noise_hz=lots: fault enc_noise_hz: 'lots' is not a number"],
        ),
        (
            ["--fault", "hbridge_pulldowns=0.5", "--fault", "uart_rx_drop=nan"],
            [
                "--fault hbridge_pulldowns=0.5: fault hbridge_pulldowns takes a whole number 0 or 1",
                "--fault uart_rx_drop=nan: fault uart_rx_drop takes a number from 0 to 1",
            ],
        ),
    ],
)
def test_bad_faults_on_the_command_line_are_a_sentence_each(
    tmp_path: Path, options: list[str], lines: list[str]
) -> None:
    done = cart2d(tmp_path, "sim", *options)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    said = done.stderr.splitlines()
    assert len(said) == len(lines)
    for line, words in zip(said, lines, strict=True):
        assert line.startswith(f"cart2d sim: {words}"), line


def encoder_distance_m(rig: Rig) -> float:
    """How far odometry says the cart went (m) while the truth says it drove 0.5 m straight."""
    start = rig.pose_now()
    truth0 = rig.sim.truth()
    assert rig.client.post("/api/goto", json={"x": 0.5, "y": 0.0}).status_code == 200
    wait_for(lambda: rig.client.get("/api/mission").json()["state"] != "driving", 60)
    truth1 = rig.sim.truth()
    end = rig.pose_now()
    driven = math.hypot(truth1["x"] - truth0["x"], truth1["y"] - truth0["y"])
    return math.hypot(end["x"] - start["x"], end["y"] - start["y"]) / driven


def test_faults_through_the_api_change_what_odometry_sees(rig: Rig) -> None:
    view = rig.client.get("/api/sim/faults").json()
    assert view["faults"] == fault_table.defaults()
    assert [f["name"] for f in view["available"]] == [f.name for f in fault_table.FAULTS]
    answer = rig.client.put("/api/sim/faults", json={"enc_slip_l": 0.2, "enc_slip_r": 0.2})
    assert answer.status_code == 200
    assert answer.json()["faults"] == {**fault_table.defaults(), "enc_slip_l": 0.2, "enc_slip_r": 0.2}
    # Both measuring wheels miss a fifth of the distance: odometry counts 0.8 of it; the cart,
    # steered by odometry, drives 0.5 / 0.8 m in truth.
    assert encoder_distance_m(rig) == pytest.approx(0.8, abs=0.01)
    assert rig.client.get("/api/sim/faults").json()["faults"]["enc_slip_l"] == 0.2
    # Left out: off again.
    assert rig.client.put("/api/sim/faults", json={}).json()["faults"] == fault_table.defaults()


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ({"enc_slip_l": 2}, "enc_slip_l: Input should be less than or equal to 0.99"),
        ({"warp": 1}, "warp: Extra inputs are not permitted"),
        ({"hbridge_pulldowns": 0.5}, "hbridge_pulldowns: Input should be a valid integer"),
        ({"enc_noise_hz": "1"}, "enc_noise_hz: Input should be a valid number"),
    ],
)
def test_bad_faults_through_the_api_change_nothing(rig: Rig, body: dict[str, object], words: str) -> None:
    rig.client.put("/api/sim/faults", json={"enc_miss_prob": 0.01})
    answer = rig.client.put("/api/sim/faults", json=body)
    assert answer.status_code == 422 and words in answer.json()["detail"]
    assert rig.sim.faults()["enc_miss_prob"] == 0.01


def test_faults_survive_a_restart_of_the_simulator(rig: Rig) -> None:
    rig.client.put("/api/sim/faults", json={"enc_track_error_m": 0.01})
    rig.sim.restart()
    assert rig.sim.faults()["enc_track_error_m"] == 0.01


def test_a_real_cart_has_no_simulator_faults(tmp_path: Path) -> None:
    """A gateway without a simulator (as `cart2d serve` builds it) answers 404 with a sentence."""
    from fastapi.testclient import TestClient

    from cart2d.server import create_app
    from tests.support.server import BASE_URL, JSON

    sim = start_sim(tmp_path)
    try:
        with Link(sim.pty) as link:
            gateway = Gateway(link, Store(tmp_path / "g"), Store(tmp_path / "g").load())  # no sim
            client = TestClient(create_app(gateway), base_url=BASE_URL, headers=JSON)
            for answer in (client.get("/api/sim/faults"), client.put("/api/sim/faults", json={})):
                assert answer.status_code == 404 and "real cart" in answer.json()["detail"]
    finally:
        sim.stop()
