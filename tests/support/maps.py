"""Hostile floor plans: a map_server YAML whose aliases multiply."""

from __future__ import annotations

YAML = "image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\n"


def alias_bomb(levels: int) -> str:
    """The billion laughs in YAML: each level nine aliases of the one before (9**levels strings)."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for k in range(1, levels):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]")
    return "\n".join(lines) + f"\n{YAML}mode: *a{levels - 1}\n"
