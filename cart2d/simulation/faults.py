"""The simulator's faults (sim/README.md, "Fault keys"), checked before they reach it: one
sentence per problem, for `cart2d sim --fault KEY=VALUE`, missions' `"faults"`, `cart2d calibrate
--faults` and PUT /api/sim/faults.

The simulator checks them too (sim/src/faults.cpp, kFields) but stops at the first problem and
only once it runs; this table repeats its keys and ranges, and tests/simulation/test_faults.py holds the
two together (every key and both ends of every range, against the real simulator)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from cart2d.shown import quoted


@dataclass(frozen=True)
class Fault:
    name: str
    low: float
    high: float
    default: float
    unit: str
    doc: str
    whole: bool = False  # only the whole numbers in [low, high]

    def range_text(self) -> str:
        if self.whole and self.high - self.low == 1:
            return f"{self.low:g} or {self.high:g}"
        return f"from {self.low:g} to {self.high:g}"


FAULTS: tuple[Fault, ...] = (
    Fault("enc_radius_scale_l", 0.5, 2.0, 1.0, "", "true / nominal radius of the left measuring wheel"),
    Fault("enc_radius_scale_r", 0.5, 2.0, 1.0, "", "true / nominal radius of the right measuring wheel"),
    Fault("enc_track_error_m", -0.1, 0.1, 0.0, "m", "true minus nominal track of the measuring wheels"),
    Fault("enc_slip_l", 0.0, 0.99, 0.0, "", "share of the distance rolled the left measuring wheel misses"),
    Fault("enc_slip_r", 0.0, 0.99, 0.0, "", "share of the distance rolled the right measuring wheel misses"),
    Fault("enc_miss_prob", 0.0, 1.0, 0.0, "", "probability that an encoder's channel-A pulse is lost"),
    Fault("enc_noise_hz", 0.0, 100000.0, 0.0, "1/s", "spurious channel-A spikes per second, per encoder"),
    Fault("uart_rx_drop", 0.0, 1.0, 0.0, "", "probability that a byte towards the MCU is dropped"),
    Fault("uart_rx_corrupt", 0.0, 1.0, 0.0, "", "probability that a byte towards the MCU has a bit flipped"),
    Fault("uart_tx_drop", 0.0, 1.0, 0.0, "", "probability that a byte from the MCU is dropped"),
    Fault("uart_tx_corrupt", 0.0, 1.0, 0.0, "", "probability that a byte from the MCU has a bit flipped"),
    Fault("uart_burst_hz", 0.0, 100.0, 0.0, "1/s", "bursts of line errors per second (both ways at once)"),
    Fault("uart_burst_ms", 0.0, 10000.0, 0.0, "ms", "how long each burst of line errors lasts"),
    Fault("uart_burst_drop", 0.0, 1.0, 0.0, "", "probability that a byte either way is lost in a burst"),
    Fault(
        "hbridge_pulldowns",
        0.0,
        1.0,
        1.0,
        "",
        "1: the H-bridge inputs' pull-down resistors are fitted; 0: missing (both bridges full on "
        "backwards while the MCU is in reset)",
        whole=True,
    ),
)
BY_NAME = {fault.name: fault for fault in FAULTS}


def defaults() -> dict[str, float]:
    """Every fault off (the simulator's state after `{"clear": true}`)."""
    return {fault.name: fault.default for fault in FAULTS}


def value_problem(name: str, value: object) -> str | None:
    """None if `value` is valid for fault `name`, else what is wrong, in a sentence."""
    fault = BY_NAME.get(name)
    if fault is None:
        return f"unknown fault {quoted(name)} (known: {', '.join(BY_NAME)})"
    if isinstance(value, bool) or not isinstance(value, int | float) or not _finite(value):
        return f"fault {name} takes a number {fault.range_text()}, not {quoted(value)}"
    if not fault.low <= value <= fault.high or (fault.whole and value != int(value)):
        whole = "a whole number" if fault.whole else "a number"
        given = f"{value:g}" if isinstance(value, float) else quoted(value)  # an int may not fit a float
        return f"fault {name} takes {whole} {fault.range_text()} ({fault.doc}), not {given}"
    return None


def _finite(value: float) -> bool:
    try:
        return math.isfinite(value)
    except OverflowError:  # an int past any float
        return False


def problems(faults: dict[str, object]) -> list[str]:
    """One sentence per problem of these faults (unknown keys, values out of range); [] if none."""
    return [p for name, value in faults.items() if (p := value_problem(name, value)) is not None]


def parse_option(text: str) -> tuple[str, float]:
    """`KEY=VALUE` of `--fault` as (key, value); ValueError with a sentence if it is not one."""
    name, sep, raw = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name:
        raise ValueError(f"{text!r} is not KEY=VALUE (for example enc_slip_l=0.05)")
    try:
        value = float(raw)
    except ValueError:
        raise ValueError(f"fault {name}: {raw.strip()!r} is not a number") from None
    problem = value_problem(name, value)
    if problem is not None:
        raise ValueError(problem)
    return name, value
