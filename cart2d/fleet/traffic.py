"""Traffic control on the shared lattice: every node is held by at most one cart; a cart's route
is released (sent as its order's base) a few nodes at a time, as far as it can hold them; a cart
that cannot hold its next node waits at the end of its base; waits that go round in a circle
(a deadlock), or that wait on a cart that is not going anywhere (parked, or OFFLINE: its nodes
stay held where it stands), are resolved by rerouting one of them round the held nodes, or, if
none can, by one of them stepping aside to a free neighbour first.

Pure logic, no clock of its own: `now` comes with each step (tests drive it with fake carts)."""

from __future__ import annotations

from dataclasses import dataclass, field

from cart2d.fleet.lattice import Cell, Lattice

LOOKAHEAD = 2  # nodes held ahead of the node a cart last passed (its base's length beyond it)


class TrafficError(ValueError):
    """A goal that cannot be given (a sentence)."""


@dataclass
class Journey:
    route: list[Cell]  # from the node it started at to its goal
    passed: int = 0  # route[passed] is the node it last reached
    released: int = 1  # route[:released] is its base (held for it)
    waiting_for: str | None = None
    waiting_since: float | None = None
    waited_s: float = 0.0
    reroutes: int = 0
    yielding: set[str] = field(default_factory=set)  # carts it stepped aside for (they go first)

    @property
    def goal(self) -> Cell:
        return self.route[-1]

    @property
    def at_base_end(self) -> bool:
        return self.passed == self.released - 1


@dataclass
class Traffic:
    lattice: Lattice
    lookahead: int = LOOKAHEAD
    holds: dict[Cell, str] = field(default_factory=dict)
    standing: dict[str, Cell] = field(default_factory=dict)  # each cart's last node
    journeys: dict[str, Journey] = field(default_factory=dict)
    offline: set[str] = field(default_factory=set)
    deadlocks: int = 0  # circles of waits resolved
    finished: list[tuple[str, Journey]] = field(default_factory=list)

    # -- carts -------------------------------------------------------------------------------
    def join(self, cart: str, cell: Cell) -> None:
        """A cart stands at `cell` (it holds it from now on)."""
        holder = self.holds.get(cell)
        if holder not in (None, cart):
            raise TrafficError(f"{cart} stands on node {cell}, which {holder} holds")
        self.standing[cart] = cell
        self.holds[cell] = cart

    def remove(self, cart: str) -> None:
        """The cart leaves the fleet: what it held is free."""
        self.journeys.pop(cart, None)
        self.standing.pop(cart, None)
        self.offline.discard(cart)
        for cell in [c for c, h in self.holds.items() if h == cart]:
            del self.holds[cell]

    def set_online(self, cart: str, online: bool) -> None:
        """An OFFLINE cart keeps what it holds until it is back or removed."""
        if online:
            self.offline.discard(cart)
        else:
            self.offline.add(cart)

    def stands_at(self, cart: str, cell: Cell) -> bool:
        """An idle cart stands nearest `cell`, one of the nodes it holds (a cancelled order's base:
        it stopped anywhere on it); its next route starts there. False if it does not hold it."""
        if self.holds.get(cell) != cart:
            return False
        self.standing[cart] = cell
        return True

    def idle(self, cart: str) -> bool:
        return cart in self.standing and cart not in self.journeys and cart not in self.offline

    # -- goals -------------------------------------------------------------------------------
    def send(self, cart: str, goal: Cell, leaving: frozenset[str] = frozenset()) -> Journey:
        """A route from where the cart stands to `goal`, round the nodes parked carts hold
        (`leaving`: carts about to get a goal of their own, not parked for long)."""
        if cart not in self.standing:
            raise TrafficError(f"{cart} is not on the map yet")
        if cart in self.journeys:
            raise TrafficError(f"{cart} is on its way to {self.journeys[cart].goal}")
        parked = self._parked(cart, leaving)
        if goal in parked:  # a moving cart's nodes are its only for a while
            raise TrafficError(f"node {goal} is held by {self.holds[goal]}, which is not going anywhere")
        route = self.lattice.route(self.standing[cart], goal, parked)
        if route is None:
            raise TrafficError(f"no route from {self.standing[cart]} to {goal} round the parked carts")
        journey = Journey(route)
        self.journeys[cart] = journey
        return journey

    def _parked(self, but: str, leaving: frozenset[str] = frozenset()) -> frozenset[Cell]:
        """Nodes held by carts that are not going anywhere (idle or OFFLINE), but `but`'s and
        those of the carts `leaving`."""
        return frozenset(
            c
            for c, h in self.holds.items()
            if h != but and (h in self.offline or (h not in self.journeys and h not in leaving))
        )

    def reached(self, cart: str, index: int) -> bool:
        """The cart reached route[index]; what it left behind is free. True at its goal."""
        journey = self.journeys.get(cart)
        if journey is None or not journey.passed <= index < journey.released:
            return False
        journey.passed = index
        self.standing[cart] = journey.route[index]
        ahead = set(journey.route[index : journey.released])
        for cell in journey.route[:index]:
            if cell not in ahead and self.holds.get(cell) == cart:
                del self.holds[cell]
        if index == len(journey.route) - 1:
            del self.journeys[cart]
            self.finished.append((cart, journey))
            return True
        return False

    def cancel(self, cart: str) -> None:
        """Its journey ends where it is: it keeps its base's nodes (it may stand anywhere on it)."""
        self.journeys.pop(cart, None)

    # -- releasing -----------------------------------------------------------------------------
    def step(self, now: float) -> set[str]:
        """Holds what each moving cart can hold next; resolves deadlocks. Returns the carts whose
        base or route changed (their order is to be updated)."""
        changed = {cart for cart in list(self.journeys) if self._extend(cart, now)}
        changed |= self._resolve(now)
        return changed

    def _extend(self, cart: str, now: float) -> bool:
        journey = self.journeys[cart]
        if cart in self.offline:
            return False
        before = journey.released
        journey.waiting_for = None
        while journey.released < len(journey.route) and journey.released - journey.passed <= self.lookahead:
            cell = journey.route[journey.released]
            if self._yields(cart, journey, cell):
                break
            holder = self.holds.get(cell)
            if holder not in (None, cart):
                journey.waiting_for = holder
                break
            self.holds[cell] = cart
            journey.released += 1
        self._count_wait(journey, now)
        return journey.released != before

    def _yields(self, cart: str, journey: Journey, cell: Cell) -> bool:
        """A cart that stepped aside takes no node the carts it made way for still have ahead."""
        journey.yielding &= set(self.journeys)
        return any(
            cell in self.journeys[other].route[self.journeys[other].passed :] for other in journey.yielding
        )

    @staticmethod
    def _count_wait(journey: Journey, now: float) -> None:
        waiting = journey.waiting_for is not None and journey.at_base_end
        if waiting and journey.waiting_since is None:
            journey.waiting_since = now
        elif not waiting and journey.waiting_since is not None:
            journey.waited_s += now - journey.waiting_since
            journey.waiting_since = None

    # -- deadlocks -----------------------------------------------------------------------------
    def _resolve(self, now: float) -> set[str]:
        changed: set[str] = set()
        for stuck in self._stuck_groups():
            resolved = self._reroute(stuck) or self._step_aside(stuck)
            if resolved:
                changed.add(resolved)
                self._extend(resolved, now)
        return changed

    def _stuck_groups(self) -> list[list[str]]:
        """Carts at their base's end waiting in a circle, or on a cart that stays where it is."""
        groups: list[list[str]] = []
        seen: set[str] = set()
        for cart in sorted(self.journeys):
            chain: list[str] = []
            current: str | None = cart
            while current is not None and current not in chain and current not in seen:
                journey = self.journeys.get(current)
                if journey is None or current in self.offline or not journey.at_base_end:
                    break  # a cart that can still move ends the chain
                chain.append(current)
                current = journey.waiting_for
            seen.update(chain)
            if current is not None and current in chain:
                self.deadlocks += 1
                groups.append(chain[chain.index(current) :])
            elif current is not None and chain and (current not in self.journeys or current in self.offline):
                groups.append(chain[-1:])  # waits on a parked or OFFLINE cart
        return groups

    def _reroute(self, carts: list[str]) -> str | None:
        """The cart of `carts` with the shortest way round every node others hold takes it."""
        best: tuple[int, str, list[Cell]] | None = None
        for cart in carts:
            journey = self.journeys[cart]
            here = journey.route[journey.released - 1]
            held = frozenset(c for c, h in self.holds.items() if h != cart)
            way = self.lattice.route(here, journey.goal, held)
            if way is not None and (best is None or len(way) < best[0]):
                best = (len(way), cart, way)
        if best is None:
            return None
        _, cart, way = best
        journey = self.journeys[cart]
        journey.route = journey.route[: journey.released] + way[1:]
        journey.reroutes += 1
        return cart

    def _step_aside(self, carts: list[str]) -> str | None:
        """One cart of `carts` goes to a free neighbour first, then on to its goal."""
        for cart in sorted(carts):
            others = [c for c in carts if c != cart] or [self.journeys[cart].waiting_for or ""]
            ahead = {
                c
                for o in others
                if o in self.journeys
                for c in self.journeys[o].route[self.journeys[o].passed :]
            }
            journey = self.journeys[cart]
            here = journey.route[journey.released - 1]
            sides = sorted(self.lattice.neighbours(here), key=lambda c: c in ahead)
            for side in sides:
                onward = self.lattice.route(side, journey.goal)
                if side in self.holds or onward is None:
                    continue
                journey.route = [*journey.route[: journey.released], side, *onward[1:]]
                journey.reroutes += 1
                journey.yielding = {o for o in others if o in self.journeys}
                return cart
        return None
