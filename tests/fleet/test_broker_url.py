"""A broker's URL: TLS, user and password passed through to the client, the password kept out of
what is printed."""

from __future__ import annotations

import pytest

from cart2d.fleet.mqtt import PASSWORD_VARIABLE, Broker


def test_plain_and_tls_urls() -> None:
    assert Broker.of("mqtt://lab.example") == Broker("lab.example", 1883)
    tls = Broker.of("mqtts://cart:s%40cret@lab.example:9883", ca_file="/etc/ca.pem")
    assert tls == Broker("lab.example", 9883, True, "cart", "s@cret", "/etc/ca.pem")
    assert str(tls) == "mqtts://cart@lab.example:9883"


def test_the_password_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(PASSWORD_VARIABLE, "hidden")
    assert Broker.of("mqtts://cart@lab.example").password == "hidden"


@pytest.mark.parametrize("url", ["tcp://lab", "mqtt://", "mqtt://lab/topic", "mqtt://lab:99999"])
def test_bad_urls(url: str) -> None:
    with pytest.raises(ValueError, match="mqtt"):
        Broker.of(url)
