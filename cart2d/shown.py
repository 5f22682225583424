"""Values as the gateway and the commands show them to people: what a user sent, quoted within
bounds (an error message never echoes unbounded input: a YAML alias bomb's value was a 226 MB
answer), and numbers without binary noise (1.2, not 1.2000000000000002)."""

from __future__ import annotations

import math
import reprlib
from collections.abc import Collection, Mapping, Sequence
from typing import Any

QUOTE_CHARS = 80  # the most characters of a value a message quotes
PEOPLE_DECIMALS = 9  # a nanometre, a nanosecond: far below anything measured, far above float noise

_quoting = reprlib.Repr()  # Python 3.11's Repr takes no arguments
_quoting.maxlevel = 2
_quoting.maxtuple = _quoting.maxlist = _quoting.maxarray = _quoting.maxdict = 4
_quoting.maxset = _quoting.maxfrozenset = _quoting.maxdeque = 4
_quoting.maxstring = _quoting.maxother = QUOTE_CHARS
_quoting.maxlong = 40


def quoted(value: object) -> str:
    """repr(value) cut to a few items per level, two levels and about QUOTE_CHARS characters."""
    try:
        text = _quoting.repr(value)
    except (RecursionError, ValueError):  # ValueError: an int over sys.get_int_max_str_digits()
        text = f"<{type(value).__name__}>"
    return text if len(text) <= QUOTE_CHARS + 10 else text[:QUOTE_CHARS] + "..."


def clipped(text: str, limit: int = 200) -> str:
    """`text` (a message that may carry input, as a library's) cut to `limit` characters."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def for_people(value: Any) -> Any:
    """`value` with every float rounded to PEOPLE_DECIMALS decimals (dicts, lists and tuples
    followed; tuples become lists, as in JSON). For views and reports, never for arithmetic."""
    if isinstance(value, float):
        return round(value, PEOPLE_DECIMALS) if math.isfinite(value) else value
    if isinstance(value, dict):
        return {key: for_people(v) for key, v in value.items()}
    if isinstance(value, list | tuple):
        return [for_people(v) for v in value]
    return value


MAX_PROBLEMS = 5  # the most problems of a validation one message lists


def error_sentences(errors: Sequence[Mapping[str, Any]], whole: str, drop: Collection[object] = ()) -> str:
    """pydantic's errors as 'where: what' joined by '; ', the first MAX_PROBLEMS and how many more;
    each location part and message cut short (a location holds the input's own keys)."""
    parts = []
    for error in errors[:MAX_PROBLEMS]:
        where = ".".join(clipped(str(p), 40) for p in error["loc"] if p not in drop) or whole
        parts.append(f"{where}: {clipped(str(error['msg']))}")
    if len(errors) > MAX_PROBLEMS:
        parts.append(f"and {len(errors) - MAX_PROBLEMS} more")
    return "; ".join(parts)
