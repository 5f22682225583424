"""The `cart2d` command's entry point (pyproject.toml, [project.scripts]). Ctrl-C ends the command
quietly at any moment: cart2d.tools.cli does so once it runs, and this does while cart2d.tools.cli
and its libraries are still being imported (seconds on a busy machine: a Ctrl-C then printed a traceback
of the import machinery)."""

from __future__ import annotations


def main() -> int:
    try:
        from cart2d.tools.cli import main as run_command

        return run_command()
    except KeyboardInterrupt:
        return 0  # what cart2d.tools.cli answers to Ctrl-C: everything stopped, nothing went wrong
