"""nav2_msgs/action/NavigateToPose on `navigate_to_pose`, driven by cart2d's own planner and
mission, so that a ROS 2 script sends the cart a goal as it would send Nav2 one.

An action is three services and two topics (rcl_action's names, rmw_cyclonedds' request
header): send_goal accepts a goal (its id, a pose in the map), which the gateway then plans and
drives; get_result is answered once the mission has ended (SUCCEEDED when it arrived, ABORTED when
it failed, CANCELED when cancel_goal stopped it); feedback carries the pose and the distance left
along the plan; status lists the goals and their states (latched). One goal at a time: a new goal
replaces the mission, and the goal it replaced is aborted."""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.convert import pose_stamped
from cart2d.ros2.frames import stamp
from cart2d.ros2.inbound import Inbound

log = logging.getLogger(__name__)

NAME = "navigate_to_pose"
ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = 1, 2, 3, 4, 5, 6  # action_msgs/GoalStatus
TERMINAL = (SUCCEEDED, CANCELED, ABORTED)
UNKNOWN_ERROR = 9000  # NavigateToPose's result code UNKNOWN (nav2_msgs, Jazzy and Kilted)
CANCEL_NONE, CANCEL_REJECTED, CANCEL_UNKNOWN_GOAL, CANCEL_TERMINATED = 0, 1, 2, 3
FEEDBACK_EVERY = 5  # telemetry frames (25 Hz): feedback at 5 Hz
KEPT_GOALS = 16  # finished goals still listed in status and answerable by get_result


class ActionGateway(Protocol):
    def go_to(self, x: float, y: float, token: int | None = None) -> Any: ...
    def stop(self, reason: str = "stopped by the user") -> Any: ...
    def motion_token(self) -> int: ...


@dataclass
class Goal:
    goal_id: bytes
    accepted: t.Time
    goal: tuple[float, float]
    started_s: float
    status: int = ACCEPTED
    error: str = ""
    waiting: list[t.NavigateToPoseGetResultRequest] = field(default_factory=list)  # get_result


def remaining_m(tel: Mapping[str, Any], waypoints: Sequence[Sequence[float]]) -> float:
    """Distance left: to the waypoint the firmware drives to, then along the rest of the plan."""
    index = int(tel.get("waypoint_index", 0))
    if not waypoints or index >= len(waypoints):
        return 0.0
    rest = sum(math.dist(waypoints[k], waypoints[k + 1]) for k in range(max(index, 0), len(waypoints) - 1))
    return float(tel.get("distance_to_waypoint", 0.0)) + rest


class NavigateToPose:
    def __init__(self, inbound: Inbound, gateway: ActionGateway, clock: Any) -> None:
        node = inbound.node
        self.options = o = node.options
        self.inbound = inbound
        self.gateway = gateway
        self.clock = clock
        self._lock = threading.Lock()
        self._goals: dict[bytes, Goal] = {}
        self._current: Goal | None = None
        self._waypoints: list[Sequence[float]] = []
        self._frames = 0
        base = f"{NAME}/_action"
        self._goal_replies = node.writer(
            o.reply(f"{base}/send_goal"), t.NavigateToPoseSendGoalResponse, qos.requests()
        )
        self._result_replies = node.writer(
            o.reply(f"{base}/get_result"), t.NavigateToPoseGetResultResponse, qos.requests()
        )
        self._cancel_replies = node.writer(
            o.reply(f"{base}/cancel_goal"), t.CancelGoalResponse, qos.requests()
        )
        self._feedback = node.writer(
            o.topic(f"{base}/feedback"), t.NavigateToPoseFeedbackMessage, qos.stream()
        )
        self._status = node.writer(o.topic(f"{base}/status"), t.GoalStatusArray, qos.latched())
        requests = qos.requests()
        inbound.add(
            node.reader(o.request(f"{base}/send_goal"), t.NavigateToPoseSendGoalRequest, requests),
            self._on_goal,
        )
        inbound.add(
            node.reader(o.request(f"{base}/get_result"), t.NavigateToPoseGetResultRequest, requests),
            self._on_result,
        )
        inbound.add(
            node.reader(o.request(f"{base}/cancel_goal"), t.CancelGoalRequest, requests), self._on_cancel
        )

    # -- requests (the reading thread) ---------------------------------------------------------
    def _on_goal(self, request: t.NavigateToPoseSendGoalRequest) -> None:
        pose = request.goal.pose
        where = self.inbound.planar(NAME, pose.header, pose.pose)
        now = stamp(self.clock())
        self._goal_replies.write(
            t.NavigateToPoseSendGoalResponse(request.guid, request.seq, accepted=where is not None, stamp=now)
        )
        if where is None:
            return
        goal = Goal(bytes(request.goal_id.uuid), now, (where[0], where[1]), self.clock())
        with self._lock:
            replaced = self._current
            self._goals[goal.goal_id] = goal
            self._current = goal
            self._forget_old()
        if replaced is not None and replaced.status not in TERMINAL:
            self._finish(replaced, ABORTED, "replaced by a newer goal")
        self._publish_status()
        token = self.gateway.motion_token()  # a stop after the goal arrived cancels it
        self.inbound.tasks.offer(f"{NAME} ({where[0]:.2f}, {where[1]:.2f})", lambda: self._start(goal, token))

    def _start(self, goal: Goal, token: int) -> None:
        with self._lock:
            if goal.status in TERMINAL:
                return  # cancelled or replaced while it waited
        try:
            plan = self.gateway.go_to(goal.goal[0], goal.goal[1], token)
        except Exception as exc:  # no route, an untrusted pose, a stop
            self._finish(goal, ABORTED, str(exc))
            return
        with self._lock:
            self._waypoints = [list(p) for p in plan.waypoints]
            if goal.status == ACCEPTED:
                goal.status = EXECUTING
        self._publish_status()

    def _on_result(self, request: t.NavigateToPoseGetResultRequest) -> None:
        with self._lock:
            goal = self._goals.get(bytes(request.goal_id.uuid))
            if goal is not None and goal.status not in TERMINAL:
                goal.waiting.append(request)
                return
        status = goal.status if goal is not None else 0
        self._result_replies.write(self._result(request, status, goal.error if goal else "unknown goal"))

    def _on_cancel(self, request: t.CancelGoalRequest) -> None:
        wanted = bytes(request.goal_info.goal_id.uuid)
        with self._lock:
            goals = [g for g in self._goals.values() if wanted in (g.goal_id, bytes(16))]
            live = [g for g in goals if g.status not in TERMINAL]
            for g in live:
                g.status = CANCELING
        if live:
            self.gateway.stop(f"the {NAME} goal was cancelled through ROS 2")
            for g in live:
                self._finish(g, CANCELED, "cancelled")
        code = CANCEL_NONE if live else (CANCEL_TERMINATED if goals else CANCEL_UNKNOWN_GOAL)
        infos = [t.GoalInfo(t.UUID(g.goal_id), g.accepted) for g in live]
        self._cancel_replies.write(t.CancelGoalResponse(request.guid, request.seq, code, infos))

    # -- the mission's progress (the bridge's worker) ------------------------------------------
    def on_message(self, message: Mapping[str, Any]) -> None:
        kind = message.get("type")
        if kind == "telemetry":
            self._frames += 1
            if self._frames % FEEDBACK_EVERY == 0:
                self._publish_feedback(message)
        elif kind == "mission":
            self._on_mission(message)

    def _on_mission(self, mission: Mapping[str, Any]) -> None:
        with self._lock:
            goal = self._current
        if goal is None or goal.status in (*TERMINAL, CANCELING) or mission.get("goal") is None:
            return  # a cancelled goal ends CANCELED, not with the stop's "failed"
        if not all(math.isclose(a, b, abs_tol=1e-6) for a, b in zip(mission["goal"], goal.goal, strict=True)):
            return
        if mission["state"] == "arrived":
            self._finish(goal, SUCCEEDED, "")
        elif mission["state"] == "failed":
            self._finish(goal, ABORTED, str(mission.get("reason", "")))

    def _publish_feedback(self, tel: Mapping[str, Any]) -> None:
        with self._lock:
            goal = self._current
            waypoints = list(self._waypoints)
        if goal is None or goal.status != EXECUTING:
            return
        now_s = self.clock()
        elapsed = max(0.0, now_s - goal.started_s)
        feedback = t.NavigateToPoseFeedback(
            current_pose=pose_stamped(
                self.options, stamp(now_s), float(tel["x"]), float(tel["y"]), float(tel["theta"])
            ),
            navigation_time=t.Duration(int(elapsed), int(elapsed % 1 * 1e9)),
            distance_remaining=remaining_m(tel, waypoints),
        )
        self._feedback.write(t.NavigateToPoseFeedbackMessage(t.UUID(goal.goal_id), feedback))

    # -- the goals' states ---------------------------------------------------------------------
    def _finish(self, goal: Goal, status: int, error: str) -> None:
        with self._lock:
            if goal.status in TERMINAL:
                return
            goal.status, goal.error = status, error
            waiting, goal.waiting = goal.waiting, []
        for request in waiting:
            self._result_replies.write(self._result(request, status, error))
        self._publish_status()
        log.info(
            "%s goal (%.2f, %.2f): %s",
            NAME,
            *goal.goal,
            {SUCCEEDED: "succeeded", CANCELED: "cancelled"}.get(status, f"aborted ({error})"),
        )

    @staticmethod
    def _result(
        request: t.NavigateToPoseGetResultRequest, status: int, error: str
    ) -> t.NavigateToPoseGetResultResponse:
        code = 0 if status == SUCCEEDED else UNKNOWN_ERROR
        return t.NavigateToPoseGetResultResponse(
            request.guid, request.seq, status, t.NavigateToPoseResult(code, error if code else "")
        )

    def _publish_status(self) -> None:
        with self._lock:
            statuses = [
                t.GoalStatus(t.GoalInfo(t.UUID(g.goal_id), g.accepted), g.status)
                for g in self._goals.values()
            ]
        self._status.write(t.GoalStatusArray(statuses))

    def _forget_old(self) -> None:
        finished = [k for k, g in self._goals.items() if g.status in TERMINAL]
        for key in finished[: max(0, len(self._goals) - KEPT_GOALS)]:
            del self._goals[key]
