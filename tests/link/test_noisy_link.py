"""Missions and stops over a serial line that loses bytes (issue 22, "a slightly noisy link ends
missions"), end to end: the real firmware in the simulator, the gateway's link, judged by the
mission's report and by ground truth in simulated time (bench/noisy_link.py measures the same
at more noise and more often)."""

from __future__ import annotations

import random
import statistics
import threading
from typing import Any

import pytest

from bench.noisy_link import BURSTS, GOALS, STOP_P99_BUDGET_S, WALL, byte_errors, stop_latency, stop_rig
from cart2d.spec import load_spec
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec

STOP = load_spec().code("STOP")


@pytest.mark.parametrize(
    ("faults", "goals"),
    [(byte_errors(0.01), GOALS + GOALS[:2]), (BURSTS, GOALS)],
    ids=["1 % of bytes each way", "bursts of lost bytes"],
)
def test_a_mission_over_a_noisy_line_reaches_every_goal(
    faults: dict[str, float], goals: list[list[float]]
) -> None:
    # At 1 %, 4 of 12 soak missions ended with "no reply to COMMAND_STATUS after 5 tries in
    # 1.3 s" or "the link failed while streaming the path".
    spec = MissionSpec.model_validate(
        {
            "grid": {"cols": 10, "rows": 10, "step": 0.2},
            "obstacles": WALL,
            "start": [0.2, 0.4, 0.0],
            "goals": goals,
            "faults": faults,
            "timeout_s": 120,
        }
    )
    report: dict[str, Any] = {}
    run_mission(spec, seed=3, report=report)
    assert "error" not in report
    assert [g.get("reason", "") for g in report["goals"]] == [""] * len(goals)
    assert report["collisions"] == 0


def test_a_stop_whose_first_transmission_is_lost_stops_the_cart_within_the_budget() -> None:
    # A lost STOP was resent only after the 250 ms an ordinary reply may take: the cart's true
    # speed fell under 20 % 137 ms (p50) to 401 ms after the request at 1 %. Here, on top of 1 %
    # of bytes each way, the line loses the first transmission of each of five STOPs (the
    # port's write swallows it); each stop is timed from its request to the cart's true speed
    # under 20 %, in simulated time, and their median held to the budget (the simulator runs in
    # real time, so a host that a busy machine holds up for a moment shows in one stop's time;
    # bench/noisy_link.py gives the percentiles). Before: 354 to 359 ms, every one.
    rng = random.Random(5)
    latencies = []
    with stop_rig(byte_errors(0.01), seed=2) as rig:
        link = rig.gateway.link
        port = link._serial
        assert port is not None
        write = port.write
        armed = threading.Event()

        def losing_the_first_stop(data: Any) -> int | None:
            if armed.is_set() and bytes(data)[3:4] == bytes([STOP]):
                armed.clear()
                return len(data)  # "written", and lost on the way
            return write(data)

        port.write = losing_the_first_stop  # type: ignore[method-assign]
        original_stop = rig.gateway.stop

        def stop(reason: str = "stopped by the user") -> Any:
            armed.set()
            return original_stop(reason)

        rig.gateway.stop = stop  # type: ignore[method-assign]
        for _ in range(5):
            latency = stop_latency(rig, rng)
            assert latency is not None and not armed.is_set()
            latencies.append(latency)
    assert statistics.median(latencies) <= STOP_P99_BUDGET_S, latencies
