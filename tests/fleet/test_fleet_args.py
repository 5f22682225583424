"""`--mqtt` and `--fleet-id` on sim and serve: a bad one is a sentence and exit status 2, before
anything starts."""

from __future__ import annotations

import pytest

from cart2d.tools.cli import main


@pytest.mark.parametrize(
    ("options", "sentence"),
    [
        (["--mqtt", "http://localhost"], "is not mqtt://HOST[:PORT]"),
        (["--mqtt", "mqtt://localhost:1883"], "--mqtt needs --fleet-id"),
        (["--mqtt", "mqtt://localhost", "--fleet-id", "a/b"], "--mqtt needs --fleet-id"),
        (["--fleet-id", "c1"], "need --mqtt"),
        (["--mqtt", "mqtts://localhost", "--fleet-id", "c1", "--mqtt-ca", "/nonexistent.pem"], "no file"),
    ],
)
@pytest.mark.parametrize("command", [["sim"], ["serve", "--serial", "/dev/null-cart2d"]])
def test_bad_fleet_options_are_refused(
    command: list[str], options: list[str], sentence: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*command, *options]) == 2
    assert sentence in capsys.readouterr().err
