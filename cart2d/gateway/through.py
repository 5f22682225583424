"""A route through several stops in turn, driven as ONE path (a fleet cart's released nodes,
issue 27): the planner's route to each stop from the one before, joined, so that the cart keeps
its speed through every stop but the last instead of stopping at each."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from cart2d.planning import Plan, Planner, Point


def plan_onward(planner: Planner, first: Plan, onward: Sequence[Point]) -> Plan:
    """`first` (a plan to the first stop) continued to each of `onward` in turn; PlanError if a
    leg has no route. Each leg's waypoints end exactly at its stop, so the next leg starts there."""
    plans = [first]
    for a, b in itertools.pairwise([first.goal, *onward]):
        plans.append(planner.plan(a, b))
    if len(plans) == 1:
        return first
    return Plan(
        start=first.start,
        goal=plans[-1].goal,
        path=first.path + tuple(p for plan in plans[1:] for p in plan.path[1:]),
        waypoints=tuple(w for plan in plans for w in plan.waypoints),
        grid_length_m=sum(plan.grid_length_m for plan in plans),
        length_m=sum(plan.length_m for plan in plans),
    )
