"""`make bench` / `make bench-quick`: runs every benchmark section and writes
bench/results/REPORT.md (with the sections' PNG plots and JSON numbers beside it).

`python -m bench.report [--quick] [--out DIR] [--only NAME ...]`; exit 1 if a target that does
not depend on the machine's load was missed (bench/common.py, Section).
"""

from __future__ import annotations

import argparse
import importlib
import platform
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from bench.common import RESULTS, Section, write_json

# In report order; each is bench/<name>.py with run(out, quick) -> Section.
SECTIONS = (
    "missions",
    "umbmark",
    "planner",
    "firmware",
    "streaming",
    "live_map",
    "perception",
    "real_photographs",
    "hard_rooms",
    "localisation",
    "camera_stream",
    "recording",
    "ros2",
    "safety",
    "drivetrain",
    "serial",
    "network_link",
    "noisy_link",
    "flashing",
    "control",
    "system",
    "fleet",
)


def _commit() -> str:
    done = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
    )
    return done.stdout.strip() or "unknown"


def _header(quick: bool, sections: list[tuple[Section, float]]) -> str:
    rows = "\n".join(f"| {s.name} | {s.verdict()} | {seconds:.0f} s |" for s, seconds in sections)
    return (
        "# cart2d benchmarks\n\n"
        f"{'The quick subset (`make bench-quick`)' if quick else 'The full suite (`make bench`)'}, "
        f"commit {_commit()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, on "
        f"{platform.machine()} Linux with {platform.python_implementation()} {platform.python_version()}. "
        "Regenerate with `make bench`; every number below comes from that run.\n\n"
        "| section | targets | took |\n|---|---|---|\n" + rows + "\n\n"
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="the subset that CI runs")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--only", nargs="*", choices=SECTIONS, help="run only these sections")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    done: list[tuple[Section, float]] = []
    for name in args.only or SECTIONS:
        print(f"bench: {name} ...", file=sys.stderr, flush=True)
        start = time.monotonic()
        module = importlib.import_module(f"bench.{name}")
        section: Section = module.run(args.out, args.quick)
        seconds = time.monotonic() - start
        write_json(
            args.out / f"{name}.json",
            {
                "targets_met": section.targets_met,
                "wall_clock_missed": section.wall_clock_missed,
                "seconds": seconds,
                **section.data,
            },
        )
        done.append((section, seconds))
        print(
            f"bench: {name} took {seconds:.0f} s, targets {section.verdict()}",
            file=sys.stderr,
        )
    report = _header(args.quick, done) + "\n".join(s.markdown for s, _ in done)
    (args.out / "REPORT.md").write_text(report)
    print(f"bench: report in {args.out / 'REPORT.md'}", file=sys.stderr)
    missed = [s for s, _ in done if not s.targets_met]
    for section in missed:
        # CI keeps only the log's tail: the missed sections' own tables say which target.
        print(f"bench: {section.name} MISSED its targets:\n{section.markdown}", file=sys.stderr)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
