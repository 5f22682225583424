"""Exploration's loop (issue 26): drive to the best frontier of what the camera has seen
(cart2d/maps/frontiers.py), again and again, while any frontier can be reached; one the cart
cannot reach or fails to reach is set aside with the reason, never sent again; a STOP ends it;
it ends with a sentence and the map saved. What it drives with is given (the gateway's go-to,
the planner's path length, the seen map), so the loop is tested without a simulator.
exploration_service.py runs it in the gateway (POST /api/explore, `cart2d explore`, the panel)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from cart2d.maps.frontiers import Point, choose, frontiers
from cart2d.maps.occupancy import FREE, OccupancyMap

MAX_GOALS = 200


@dataclass
class Progress:
    goals: int = 0
    seen_free_m2: float = 0.0
    frontiers: int = 0
    elapsed_s: float = 0.0
    set_aside: dict[Point, str] = field(default_factory=dict)
    sentence: str = ""


@dataclass
class Explorer:
    seen: Callable[[], OccupancyMap]  # what the camera has seen, in map
    path_length: Callable[[Point], float | None]  # None: no path there
    go_to: Callable[[Point], str]  # drives there; "" once arrived, else why not
    stopped: Callable[[], bool]  # the user's STOP since the start
    save: Callable[[], str]  # writes the map; where, in words
    tell: Callable[[Progress], None] = lambda progress: None
    clock: Callable[[], float] = time.monotonic
    # path lengths for a second choice when the first finds none (a way it left out as unsafe
    # for now, taken rather than ending with floor unseen); None: no second choice
    last_resort: Callable[[Point], float | None] | None = None

    def run(self, max_goals: int = MAX_GOALS) -> Progress:
        progress = Progress()
        started = self.clock()
        while True:
            seen = self.seen()
            found = frontiers(seen)
            progress.frontiers = len(found)
            progress.seen_free_m2 = float(np.count_nonzero(seen.cells == FREE)) * seen.resolution_m**2
            progress.elapsed_s = self.clock() - started
            self.tell(progress)
            if self.stopped():
                progress.sentence = "exploration stopped by the user"
                break
            if progress.goals >= max_goals:
                progress.sentence = f"exploration gave up after {max_goals} goals"
                break
            target = choose(found, seen.resolution_m, self.path_length, progress.set_aside)
            if target is None and self.last_resort is not None:
                target = choose(found, seen.resolution_m, self.last_resort, progress.set_aside)
            if target is None and self.stopped():  # the choice found why it cannot go on
                progress.sentence = "exploration stopped by the user"
                break
            if target is None:
                aside = len(progress.set_aside)
                seen_m2 = f"{progress.seen_free_m2:.1f} m² of floor seen"
                progress.sentence = (
                    f"exploration finished: no reachable frontier left ({seen_m2}, "
                    f"{aside} frontier{'s' if aside != 1 else ''} set aside)"
                )
                break
            progress.goals += 1
            why_not = self.go_to(target.centre)
            if why_not:
                progress.set_aside[target.centre] = why_not
        progress.sentence += f"; {self.save()}"
        progress.elapsed_s = self.clock() - started
        self.tell(progress)
        return progress
