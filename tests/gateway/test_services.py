"""The gateway's services on their own, wired as Gateway.__init__ wires them but without it: the
missions (missions.py), the reset routine (routine.py) and the STATUS monitor (monitor.py), on a
fake firmware (fake_firmware.py) and a fake clock. No simulator, no thread: the test turns the
monitor's round (Monitor.look) where its thread would."""

from __future__ import annotations

import threading

import pytest

from cart2d.gateway.bus import Closing, Event, EventBus, MapChanged, MissionEnded, ViewerMessage
from cart2d.gateway.commands import Commands
from cart2d.gateway.live_map import planner_for
from cart2d.gateway.missions import Missions
from cart2d.gateway.monitor import Monitor
from cart2d.gateway.restarts import Restarts
from cart2d.gateway.routine import ResetRoutine
from cart2d.gateway.status_cache import StatusCache
from cart2d.planning import Planner
from cart2d.spec import load_spec
from cart2d.store import MapSettings
from tests.support.fake_firmware import FakeFirmware
from tests.support.waiting import wait_for

ACROSS = [(1.0, 0.6), (1.0, 0.8), (1.0, 1.0)]  # three nodes across the straight route at y = 0.8
GOAL = (1.6, 0.8)


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Rig:
    """The services of one gateway: what Gateway.__init__ wires, with fakes for the rest."""

    def __init__(self) -> None:
        self.cart = FakeFirmware()
        self.cart.pose = [0.2, 0.8, 0.0]
        self.clock = FakeClock()
        self.bus = EventBus()
        self.events: list[Event] = []
        self.bus.subscribe(Event, self.events.append)
        self.planner: Planner = planner_for(MapSettings())
        self.trusted: list[str] = []
        self.wakes = 0
        lock = threading.RLock()
        cache = StatusCache()
        self.restarts = Restarts(
            self.cart, cache, self.bus, self.pose, lambda r, rr: self.missions.restart_ended(r, rr)
        )
        self.monitor = Monitor(self.cart, self.bus, self.restarts.read_status, self.pose, lambda: 0.0)
        self.routine = ResetRoutine(lock, self.bus, self.pose, self.trust)
        self.missions = Missions(
            self.cart,
            self.bus,
            self.restarts,
            self.routine,
            lock,
            planner=lambda: self.planner,
            read_pose=self.pose,
            look=lambda goal, token, driving: 0,
            forwards_only=lambda certain: None,
            wait_for_the_program=lambda: None,
            sim_time=lambda: None,
            wake=self.wake,
            clock=self.clock,
        )
        self.monitor.follow(self.missions)
        self.monitor.follow(self.routine)
        self.commands = Commands(self.cart, self.restarts, self.missions, self.routine, self.pose, self.wake)
        self.restarts.read_status()  # the baseline

    def pose(self) -> tuple[float, float, float]:
        x, y, theta = self.cart.call("POSE")
        return x, y, theta

    def trust(self, how: str) -> None:
        self.trusted.append(how)
        self.restarts.trust(how)

    def wake(self) -> None:
        self.wakes += 1

    def ended(self) -> list[MissionEnded]:
        return [e for e in self.events if isinstance(e, MissionEnded)]

    def told(self, kind: str) -> list[dict[str, object]]:
        return [e.wire for e in self.events if isinstance(e, ViewerMessage) and e.wire["type"] == kind]

    def block_the_route(self) -> None:
        """A box across the straight route, put on the map as map_edits.py does."""
        graph = self.planner.grid
        self.planner.set_obstacles(sorted(graph.nearest_node(x, y) for x, y in ACROSS))
        self.bus.publish(MapChanged(2, "a box was put down"))


@pytest.fixture
def rig() -> Rig:
    return Rig()


def test_go_to_then_stop_ends_the_mission_once_with_the_stops_reason(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.clock.now += 2.5
    rig.missions.stop("the user pressed the red button")
    rig.monitor.look()  # the firmware is idle now: the mission is ended already, not again
    assert rig.ended() == [MissionEnded(GOAL, "failed", "the user pressed the red button")]
    view = rig.missions.mission_view()
    assert view["reason"] == "the user pressed the red button" and view["elapsed_s"] == 2.5
    assert rig.missions.stops_pending() == 0 and rig.missions.mission.resumable


def test_a_stop_answered_while_the_lock_is_held_is_recorded_once_it_is_free(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    with rig.missions.lock:
        held = threading.Thread(target=rig.missions.stop, args=("stopped while planning",))
        held.start()
        held.join(5.0)
        assert not held.is_alive() and rig.cart.mode == "IDLE"  # answered: the STOP went first
    wait_for(lambda: not rig.missions.stops_pending(), 10)  # its thread takes the lock once free
    assert rig.ended() == [MissionEnded(GOAL, "failed", "stopped while planning")]


def test_two_faults_end_the_mission_once_with_the_first_ones_reason(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.cart.restart()
    rig.monitor.look()  # the restart ends it, through abort
    assert rig.missions.abort("the camera went blind") is None  # a second fault: nothing left to end
    (ended,) = rig.ended()
    assert ended.outcome == "failed" and ended.reason.startswith("the controller restarted")
    assert rig.missions.mission_view()["reason"] == ended.reason
    assert not rig.missions.mission.resumable  # a restart loses the path


def test_the_firmware_stopping_the_path_ends_the_mission_once_with_its_words(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.cart.mode, rig.cart.flags = "IDLE", {"BUMPER"}
    rig.monitor.look()
    rig.monitor.look()
    assert rig.ended() == [
        MissionEnded(
            GOAL,
            "failed",
            "the cart touched something in front: a front switch closed and the firmware stopped it",
        )
    ]


def test_a_route_the_map_blocks_is_replanned_round_the_box(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    straight = list(rig.cart.path)
    rig.clock.now += 1.0
    rig.block_the_route()
    (replan,) = rig.missions.mission.replans
    assert (replan.outcome, replan.reason) == ("replanned", "the map changed: a box was put down")
    assert replan.at_s == 1.0 and replan.sim_t is None
    assert rig.cart.path != straight and rig.cart.path[-1] == pytest.approx(GOAL)
    assert rig.missions.mission_view()["state"] == "driving" and rig.ended() == []
    assert rig.told("replan")[0]["outcome"] == "replanned"


def test_a_replan_with_no_path_left_stops_the_cart_and_ends_the_mission_once(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.planner.set_obstacles([rig.planner.grid.nearest_node(*GOAL)])
    rig.bus.publish(MapChanged(2, "a box on the goal"))
    (ended,) = rig.ended()
    assert ended.reason.startswith("the map changed: a box on the goal, and no path remains")
    assert rig.cart.mode == "IDLE" and "STOP" in rig.cart.requests


def test_start_resumes_the_mission_a_stop_ended(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.missions.stop()
    assert rig.missions.mission_view()["state"] == "failed"
    rig.cart.call("START")  # as Gateway.command sends it, then hands it on
    rig.missions.resume(None)
    assert rig.missions.mission_view() | {"plan": None} == {
        "state": "driving",
        "goal": list(GOAL),
        "reason": "",
        "elapsed_s": 0.0,
        "plan": None,
        "replans": [],
    }
    assert rig.wakes == 1  # the monitor follows it again at once
    rig.cart.arrive()
    rig.monitor.look()
    assert rig.ended()[-1] == MissionEnded(GOAL, "arrived", "")


def test_start_resumes_nothing_after_manual_driving_replaced_the_path(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.missions.stop()
    rig.missions.drive(0.1, 0.0)
    rig.cart.call("START")
    rig.missions.resume(None)
    assert rig.missions.mission_view()["state"] == "failed" and rig.wakes == 0


def test_the_routine_ends_squared_up_and_the_pose_is_trusted(rig: Rig) -> None:
    rig.cart.call("RESET_ROUTINE")
    rig.routine.start((0.5, 0.1, 1.5))
    rig.monitor.look()  # still creeping
    assert rig.routine.view()["state"] == "running"
    rig.cart.mode, rig.cart.pose = "IDLE", [0.5, 0.1, 1.5]
    rig.monitor.look()
    assert rig.routine.view() == {
        "state": "done",
        "words": "squared up against the wall: pose (0.500 m, 0.100 m, 85.9°)",
    }
    assert rig.trusted and rig.trusted[0].startswith("the reset routine squared the cart up")


@pytest.mark.parametrize(
    ("flags", "pose", "words"),
    [
        ({"ROUTINE_FAILED"}, [0.2, 0.8, 0.0], "it found no wall in time: the pose is unchanged"),
        (set(), [0.4, 0.1, 1.5], "it was interrupted before it squared up"),
    ],
)
def test_the_routine_fails_without_a_wall_or_short_of_the_reset_pose(
    rig: Rig, flags: set[str], pose: list[float], words: str
) -> None:
    rig.routine.start((0.5, 0.1, 1.5))
    rig.cart.mode, rig.cart.flags, rig.cart.pose = "IDLE", flags, pose
    rig.monitor.look()
    assert rig.routine.view() == {"state": "failed", "words": words} and not rig.trusted


def test_the_routine_replaces_the_mission_and_a_path_replaces_the_routine(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    rig.routine.start((0.5, 0.1, 1.5))
    assert rig.ended() == [MissionEnded(GOAL, "failed", "replaced by the reset routine")]
    rig.missions.go_to(*GOAL)
    assert rig.routine.view() == {"state": "failed", "words": "a path replaced it before it squared up"}


def test_a_fault_ends_the_mission_and_the_routine_together_once(rig: Rig) -> None:
    rig.routine.start((0.5, 0.1, 1.5))
    rig.missions.abort("a fault")
    rig.missions.abort("another fault")
    assert rig.told("routine")[1:] == [
        {"type": "routine", "state": "failed", "words": "a fault before it squared up"}
    ]


def test_the_monitor_is_woken_by_a_tick_that_went_backwards_and_closes_on_closing(rig: Rig) -> None:
    for tick in (10, 11, 5):
        rig.monitor.on_tick(tick)
    assert rig.monitor.woken.is_set()
    rig.monitor.start()
    rig.bus.publish(Closing())  # Gateway.close's one shutdown path
    assert not rig.monitor._thread.is_alive()


def command(rig: Rig, name: str, *args: float) -> None:
    reply = rig.commands.command(load_spec().code(name), args)
    assert reply.ok


def test_start_through_the_command_form_resumes_and_a_users_path_does_not(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    command(rig, "STOP")
    command(rig, "START")
    assert rig.missions.mission_view()["state"] == "driving"
    command(rig, "STOP")
    command(rig, "WAIT_XY_ARRAY", 1, 0.4, 0.8)  # the user's own path replaces the mission's
    command(rig, "START")
    view = rig.missions.mission_view()
    assert (view["state"], view["reason"]) == ("failed", "stopped by the user")


def test_the_reset_routine_through_the_command_form_replaces_the_mission_and_is_followed(rig: Rig) -> None:
    rig.missions.go_to(*GOAL)
    command(rig, "RESET_ROUTINE")
    assert rig.ended() == [MissionEnded(GOAL, "failed", "replaced by the reset routine")]
    assert rig.routine.view()["state"] == "running" and rig.wakes == 1


def test_a_pose_set_through_the_command_form_is_trusted_again(rig: Rig) -> None:
    rig.cart.restart()
    rig.monitor.look()
    assert not rig.restarts.pose_trust.trusted
    command(rig, "SET_POSE", 0.3, 0.4, 0.0)
    assert rig.restarts.pose_trust.trusted
    assert rig.told("pose_trust")[-1]["how"] == "the pose was set to (0.300 m, 0.400 m, 0.0°) with SET_POSE"
