"""The command line's part of localisation (docs/localisation.md): `--markers FILE` on `cart2d
sim` and `cart2d serve`, and `cart2d tags print`, the printable sheets of the markers."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

from cart2d.gateway.bus import EventBus, SimulatorRestarted
from cart2d.gateway.localisation import Localisable, Localisation, localise
from cart2d.gateway.seeing import default_latency_s
from cart2d.localisation.markers import BITMAP_CELLS, TAG_IDS, MarkerMap, MarkersError, bitmap, load_markers
from cart2d.perception.calibration import calibration_path, load_calibration
from cart2d.perception.camera_model import Intrinsics, Mount
from cart2d.simulation.markers import Controls, place_markers
from cart2d.tools.camera_calibration.simulated import simulated_lens

MM_PER_INCH = 25.4
MAX_TAGS_PRINTED = 100


def add_markers_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--markers",
        type=Path,
        metavar="FILE",
        help="AprilTag 36h11 markers at surveyed places in the map (JSON or YAML: docs/localisation.md): "
        "the pose is corrected whenever the camera sees one",
    )


def markers_of(args: argparse.Namespace) -> tuple[MarkerMap | None, str | None]:
    """The --markers file's markers (None without it), or the sentence why it cannot be used."""
    if args.markers is None:
        return None, None
    try:
        return load_markers(args.markers), None
    except MarkersError as exc:
        return None, str(exc)


def lens_for(directory: Path, mount: Mount, simulated: bool) -> Intrinsics:
    """The camera's calibration if one was saved; the simulator's own lens in the simulator
    (what `cart2d camera calibrate --sim` recovers), else the nominal lens."""
    path = calibration_path(directory)
    if simulated and not path.exists():
        return simulated_lens(mount)
    return load_calibration(path, mount).intrinsics


def start_localisation(
    gateway: Localisable, markers: MarkerMap, directory: Path, sim: Controls | None = None
) -> Localisation:
    mount = Mount.from_robot()
    if sim is not None:
        place_markers(sim, markers)  # the simulated camera sees them where the file says
        replace_after_restarts(gateway.bus, sim, markers)
    return localise(gateway, markers, lens_for(directory, mount, sim is not None), mount, default_latency_s())


def replace_after_restarts(bus: EventBus, sim: Controls, markers: MarkerMap) -> None:
    """A simulator its supervisor started again has no markers: they are sent again."""

    def again(event: SimulatorRestarted) -> None:
        if not event.error:
            place_markers(sim, markers)

    bus.subscribe(SimulatorRestarted, again)


# -- cart2d tags print -------------------------------------------------------------------------------
def add_print_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "ids", nargs="*", help="marker ids to print (0 to 586; A-B for a range); default: those of --markers"
    )
    parser.add_argument(
        "--markers", type=Path, metavar="FILE", help="print the markers of this file, at their sizes"
    )
    parser.add_argument(
        "--size-mm", type=float, default=100.0, help="side of the black square for ids given (default 100 mm)"
    )
    parser.add_argument("--dpi", type=int, default=300, help="printer resolution (default 300)")
    parser.add_argument(
        "--out",
        type=Path,
        required=True,
        help="FILE.pdf (one page per marker, at true size: print at 100 %%) or FILE.png (one file per "
        "marker, FILE-ID.png, its DPI recorded)",
    )


def _ids(words: list[str]) -> list[int]:
    out: list[int] = []
    for word in words:
        first, _, last = word.partition("-")
        if not (first.isdigit() and (not last or last.isdigit())):
            raise ValueError(f"{word!r} is not an id or a range A-B")
        lo, hi = int(first), int(last or first)
        if not (0 <= lo <= hi < TAG_IDS):
            raise ValueError(f"{word!r}: ids run from 0 to {TAG_IDS - 1}")
        out.extend(range(lo, hi + 1))
    return out


def sheet(tag_id: int, size_mm: float, dpi: int) -> Image.Image:
    """One marker at true size: the black square `size_mm` wide, a white margin of two cells
    round it (the detector needs one), its id and size written underneath."""
    cell_px = size_mm / MM_PER_INCH * dpi / BITMAP_CELLS
    margin = 2
    side = round((BITMAP_CELLS + 2 * margin) * cell_px)
    caption = max(12, round(cell_px))
    page = Image.new("L", (side, side + caption), 255)
    cells = (bitmap(tag_id) * 255).astype(np.uint8)
    inner = round(BITMAP_CELLS * cell_px)
    tag = Image.fromarray(cells).resize((inner, inner), Image.Resampling.NEAREST)
    page.paste(tag, (round(margin * cell_px), round(margin * cell_px)))
    text = f"AprilTag 36h11 id {tag_id}, {size_mm:g} mm (black square)"
    ImageDraw.Draw(page).text((round(margin * cell_px), side - caption // 2), text, fill=0)
    return page


def cmd_tags_print(args: argparse.Namespace) -> int:
    try:
        wanted: list[tuple[int, float]] = [(i, args.size_mm) for i in _ids(args.ids)]
    except ValueError as exc:
        print(f"cart2d tags print: {exc}", file=sys.stderr)
        return 2
    if args.markers is not None:
        markers, problem = markers_of(args)
        if problem or markers is None:
            print(f"cart2d tags print: {problem}", file=sys.stderr)
            return 2
        wanted += [(m.id, m.size_m * 1000) for m in markers.markers]
    suffix = args.out.suffix.lower()
    problems = []
    if not wanted:
        problems.append("name ids to print, or a --markers file")
    if len(wanted) > MAX_TAGS_PRINTED:
        problems.append(f"at most {MAX_TAGS_PRINTED} markers at once")
    if suffix not in (".pdf", ".png"):
        problems.append(f"--out must end in .pdf or .png, not {args.out.name!r}")
    if not (10.0 <= args.size_mm <= 1000.0) or not (72 <= args.dpi <= 1200):
        problems.append("--size-mm takes 10 to 1000 mm, --dpi 72 to 1200")
    for problem in problems:
        print(f"cart2d tags print: {problem}", file=sys.stderr)
    if problems:
        return 2
    pages = [sheet(i, size, args.dpi) for i, size in wanted]
    written = _write(pages, [i for i, _ in wanted], args.out, args.dpi)
    names = ", ".join(str(p) for p in written)
    print(f"wrote {names}: print at 100 % (actual size), then measure the black square")
    return 0


def _write(pages: list[Image.Image], ids: list[int], out: Path, dpi: int) -> list[Path]:
    if out.suffix.lower() == ".pdf":
        extra: dict[str, Any] = {"save_all": True, "append_images": pages[1:]}
        pages[0].save(out, "PDF", resolution=float(dpi), **extra)
        return [out]
    paths = [out] if len(pages) == 1 else [out.with_name(f"{out.stem}-{i}{out.suffix}") for i in ids]
    for page, path in zip(pages, paths, strict=True):
        page.save(path, "PNG", dpi=(dpi, dpi))
    return paths
