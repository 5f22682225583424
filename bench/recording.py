"""## Recordings: what an MCAP flight recorder costs and holds

A mission through a wall with a gap (the simulator at full speed) runs with and without its MCAP
recording (cart2d/recording/: every channel of the Foxglove live view, plus the JSON of /ws);
the file is read back with the `mcap` package. Reported: the file's size per simulated second,
messages per simulated second per channel, the time to read the file back, and what recording
costs the gateway's process: its CPU time per simulated second with and without recording (the
simulator is another process), which at 1x real time is the share of a core it takes. The runs
alternate, with and without, so that the load of the machine falls on both alike.

`python -m bench.recording [--quick]`.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from bench.common import Section, section_main, spread, table
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec

MISSION = {
    "obstacles": [[0.8, y / 10] for y in range(0, 14, 2)],
    "start": [0.2, 0.2, 0.0],
    "goals": [[1.6, 0.4], [1.6, 1.6], [0.2, 0.2]],
}
MAX_CORE_SHARE = 0.05  # recording may take at most this share of a core on a cart at 1x real time


def _read_back(path: Path) -> tuple[Counter[str], float]:
    began = time.perf_counter()
    counts: Counter[str] = Counter()
    with path.open("rb") as stream:
        for _, channel, _ in make_reader(stream).iter_messages():
            counts[channel.topic] += 1
    return counts, time.perf_counter() - began


def _run(recorded: bool, folder: Path) -> dict[str, Any]:
    path = folder / f"run-{time.monotonic_ns()}.mcap" if recorded else None
    cpu_began = time.process_time()
    report = run_mission(MissionSpec.model_validate(MISSION), mcap_path=path)
    cpu_s = time.process_time() - cpu_began
    if not all(goal["reached"] for goal in report["goals"]):
        raise RuntimeError(f"the benchmark mission failed: {report}")
    sim_s = report["sim_time_s"]
    result: dict[str, Any] = {
        "rtf": report["real_time_factor"],
        "sim_s": sim_s,
        "cpu_per_sim_s": cpu_s / sim_s,
    }
    if path is not None:
        counts, read_s = _read_back(path)
        result.update(bytes=path.stat().st_size, counts=dict(counts), read_s=read_s)
    return result


def run(out: Path, quick: bool) -> Section:
    repeats = 1 if quick else 3
    plain: list[dict[str, Any]] = []
    recorded: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            plain.append(_run(False, Path(tmp)))
            recorded.append(_run(True, Path(tmp)))
    rtf_plain = spread([r["rtf"] for r in plain])
    rtf_recorded = spread([r["rtf"] for r in recorded])
    last = recorded[-1]
    sim_s = last["sim_s"]
    kib_per_s = spread([r["bytes"] / 1024 / r["sim_s"] for r in recorded])
    rows = [
        (topic, count, f"{count / sim_s:.1f}")
        for topic, count in sorted(last["counts"].items(), key=lambda kv: -kv[1])
    ]
    cpu_plain = spread([r["cpu_per_sim_s"] for r in plain])
    cpu_recorded = spread([r["cpu_per_sim_s"] for r in recorded])
    overhead = cpu_recorded.median - cpu_plain.median
    cheap = overhead <= MAX_CORE_SHARE  # CPU time against the wall clock: reported, not failed
    markdown = (
        (__doc__ or "")
        + "\n"
        + table(
            ["", "measured", "target"],
            [
                ("file size", f"{kib_per_s.text('.1f', 'KiB')} per simulated second", ""),
                ("read back (mcap)", spread([r["read_s"] for r in recorded]).text(".3f", "s"), ""),
                ("gateway CPU s per simulated s, without recording", cpu_plain.text(".3f"), ""),
                ("gateway CPU s per simulated s, with recording", cpu_recorded.text(".3f"), ""),
                ("cost of recording at 1x real time", f"{overhead:.1%} of a core", f"≤ {MAX_CORE_SHARE:.0%}"),
                (
                    "real-time factor without / with recording",
                    f"{rtf_plain.text('.1f')} / {rtf_recorded.text('.1f')}",
                    "",
                ),
            ],
        )
        + f"\nMessages of the last run ({sim_s:.1f} simulated seconds, {last['bytes'] / 1024:.0f} KiB):\n\n"
        + table(["channel", "messages", "per simulated second"], rows)
    )
    data = {
        "kib_per_sim_s": kib_per_s.as_dict(),
        "rtf_plain": rtf_plain.as_dict(),
        "rtf_recorded": rtf_recorded.as_dict(),
        "cpu_per_sim_s_plain": cpu_plain.as_dict(),
        "cpu_per_sim_s_recorded": cpu_recorded.as_dict(),
        "core_share": overhead,
        "counts": last["counts"],
        "sim_s": sim_s,
    }
    slow = [] if cheap else [f"recording costs ≤ {MAX_CORE_SHARE:.0%} of a core ({overhead:.1%})"]
    return Section("recording", markdown, data, True, slow)


if __name__ == "__main__":
    sys.exit(section_main(run))
