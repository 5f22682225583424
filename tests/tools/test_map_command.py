"""`cart2d map save`: a bad name is refused with a sentence and exit status 2, before any request."""

from __future__ import annotations

import pytest

from cart2d.tools import cli


def test_map_save_refuses_a_bad_name_before_asking_the_gateway(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["map", "save", "../x", "--url", "http://127.0.0.1:9"]) == 2
    assert "a map's name is" in capsys.readouterr().err
