"""What every benchmark section shares: statistics, the result files, the command line.

A section is a module `bench/<name>.py` with `run(out: Path, quick: bool) -> Section`. It writes
its PNG plots into `out` (matplotlib, file names `<name>_*.png`) and returns its Markdown (which
links the plots by bare file name) and its raw numbers; `bench/report.py` writes them into
`out/<name>.json` and assembles `REPORT.md`. `python -m bench.<name> [--quick]` runs one alone.
A target on wall-clock speed (a rate, a latency, CPU time per frame) is reported when missed but
never fails the run: only what does not depend on the machine's load does (correctness,
simulated time, ratios measured side by side).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only, no display

RESULTS = Path(__file__).resolve().parent / "results"


@dataclass
class Section:
    """One section of the report: its Markdown, its numbers, and whether its targets were met."""

    name: str
    markdown: str
    data: dict[str, Any] = field(default_factory=dict)
    targets_met: bool = True  # the targets that do not depend on the machine's load
    # Targets on wall-clock speed this run missed: reported, never a failure (a busy machine
    # misses them with nothing wrong in cart2d).
    wall_clock_missed: list[str] = field(default_factory=list)

    def verdict(self) -> str:
        """'met', '**MISSED**', or 'met' with the wall-clock targets this machine missed."""
        if not self.targets_met:
            return "**MISSED**"
        if self.wall_clock_missed:
            return "met; on this machine's wall clock missed: " + "; ".join(self.wall_clock_missed)
        return "met"


@dataclass(frozen=True)
class Spread:
    """The median of repeated measurements with their range."""

    median: float
    low: float
    high: float
    n: int

    def text(self, fmt: str = ".3g", unit: str = "") -> str:
        """'1.23 (1.20 to 1.31)': the median, then the range when there was more than one run."""
        u = f" {unit}" if unit else ""
        if self.n <= 1 or self.low == self.high:
            return f"{self.median:{fmt}}{u}"
        return f"{self.median:{fmt}}{u} ({self.low:{fmt}} to {self.high:{fmt}})"

    def as_dict(self) -> dict[str, float]:
        return {"median": self.median, "low": self.low, "high": self.high, "n": self.n}


def missed(checks: Sequence[tuple[str, bool]]) -> list[str]:
    """The names of the checks that did not hold."""
    return [name for name, ok in checks if not ok]


def spread(values: Sequence[float]) -> Spread:
    if not values:
        raise ValueError("no measurements")
    return Spread(statistics.median(values), min(values), max(values), len(values))


def percentile(values: Sequence[float], q: float) -> float:
    """The q-th percentile (0..100), linear between closest ranks."""
    if not values:
        raise ValueError("no measurements")
    ordered = sorted(values)
    pos = (len(ordered) - 1) * q / 100.0
    lo = int(pos)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (pos - lo)


def table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def write_json(path: Path, data: Any) -> None:
    """Written atomically: a reader never sees half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(data, f, indent=2)
        f.write("\n")
    os.replace(tmp, path)


def section_main(run: Callable[[Path, bool], Section], argv: Sequence[str] | None = None) -> int:
    """`python -m bench.<name> [--quick] [--out DIR]`: runs one section, writes its JSON and its
    Markdown beside the plots, prints the Markdown; exit 1 if a target was missed."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="the small subset that CI runs")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    section = run(args.out, args.quick)
    write_json(
        args.out / f"{section.name}.json",
        {"targets_met": section.targets_met, "wall_clock_missed": section.wall_clock_missed, **section.data},
    )
    (args.out / f"{section.name}.md").write_text(section.markdown)
    print(section.markdown)
    if not section.targets_met or section.wall_clock_missed:
        print(f"{section.name}: targets {section.verdict()}", file=sys.stderr)
    return 0 if section.targets_met else 1
