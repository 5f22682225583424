"""The MQTT client both sides use (paho-mqtt, threaded: the gateway's services are threads):
a broker's URL with its TLS and credentials, a last will, subscriptions made again at every
(re)connection, and JSON in and out.

A broker that restarts is connected to again by paho's loop (1 s between tries at most); what
was published with QoS 1 while it was away is sent once it is back (paho keeps it)."""

from __future__ import annotations

import contextlib
import json
import logging
import os
import ssl
import threading
import urllib.parse
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import paho.mqtt.client as paho
from paho.mqtt.enums import CallbackAPIVersion

log = logging.getLogger(__name__)

PASSWORD_VARIABLE = "CART2D_MQTT_PASSWORD"  # the password when the URL names only a user


@dataclass(frozen=True)
class Broker:
    host: str
    port: int
    tls: bool = False
    username: str | None = None
    password: str | None = None
    ca_file: str | None = None  # TLS: the CA that signed the broker's certificate (default: the system's)

    @classmethod
    def of(cls, url: str, ca_file: str | None = None) -> Broker:
        """mqtt://[USER[:PASSWORD]@]HOST[:PORT] or mqtts://... (TLS; port 8883 by default);
        ValueError with a sentence for anything else."""
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("mqtt", "mqtts") or not parts.hostname:
            raise ValueError(f"{url!r} is not mqtt://HOST[:PORT] or mqtts://HOST[:PORT]")
        if parts.path not in ("", "/") or parts.query:
            raise ValueError(f"{url!r}: a broker's URL has no path or query")
        tls = parts.scheme == "mqtts"
        try:
            port = parts.port or (8883 if tls else 1883)
        except ValueError as exc:
            raise ValueError(f"{url!r}: {exc}") from exc
        user = urllib.parse.unquote(parts.username) if parts.username else None
        password = urllib.parse.unquote(parts.password) if parts.password else None
        if user and password is None:
            password = os.environ.get(PASSWORD_VARIABLE)
        return cls(parts.hostname, port, tls, user, password, ca_file)

    def __str__(self) -> str:
        """The URL without its password (for logs and banners)."""
        user = f"{self.username}@" if self.username else ""
        return f"{'mqtts' if self.tls else 'mqtt'}://{user}{self.host}:{self.port}"


Handler = Callable[[str, dict[str, Any]], None]


class Connection:
    """One client: `will` is (topic, payload) sent retained by the broker if this client is lost;
    `on_connect` runs at every (re)connection (what must be published again, retained messages
    a restarted broker forgot)."""

    def __init__(
        self,
        broker: Broker,
        client_id: str,
        will: tuple[str, dict[str, Any]] | None = None,
        on_connect: Callable[[], None] | None = None,
    ) -> None:
        self.broker = broker
        self._subscriptions: dict[str, Handler] = {}
        self._on_connect = on_connect
        self.connected = threading.Event()
        self.connections = 0  # how many times it connected
        client = paho.Client(CallbackAPIVersion.VERSION2, client_id=client_id, protocol=paho.MQTTv311)
        client.reconnect_delay_set(min_delay=1, max_delay=1)  # a restarted broker is back within 1 s
        if broker.username:
            client.username_pw_set(broker.username, broker.password)
        if broker.tls:
            client.tls_set(ca_certs=broker.ca_file, cert_reqs=ssl.CERT_REQUIRED)
        if will is not None:
            client.will_set(will[0], json.dumps(will[1]), qos=1, retain=True)
        client.on_connect = self._connected
        client.on_disconnect = self._disconnected
        client.on_message = self._message
        self._client = client

    def start(self) -> Connection:
        """Connects in the background (and again whenever the connection is lost)."""
        self._client.connect_async(self.broker.host, self.broker.port, keepalive=5)
        self._client.loop_start()
        return self

    def wait(self, timeout_s: float) -> bool:
        return self.connected.wait(timeout_s)

    def subscribe(self, topic: str, handler: Handler) -> None:
        """handler(topic, payload) on paho's thread for every JSON object on `topic` (a filter)."""
        self._subscriptions[topic] = handler
        if self.connected.is_set():
            self._client.subscribe(topic, qos=1)

    def publish(self, topic: str, payload: dict[str, Any], retain: bool = False, qos: int = 1) -> None:
        self._client.publish(topic, json.dumps(payload), qos=qos, retain=retain)

    def close(self, last: tuple[str, dict[str, Any]] | None = None) -> None:
        """Disconnects in order, after publishing `last` (retained) if connected."""
        if last is not None and self.connected.is_set():
            info = self._client.publish(last[0], json.dumps(last[1]), qos=1, retain=True)
            with contextlib.suppress(RuntimeError, ValueError):
                info.wait_for_publish(2.0)
        self._client.disconnect()
        self._client.loop_stop()

    def _connected(self, client: paho.Client, _data: Any, _flags: Any, reason: Any, _props: Any) -> None:
        if reason.is_failure:
            log.warning("the broker %s refused the connection: %s", self.broker, reason)
            return
        self.connections += 1
        for topic in self._subscriptions:
            client.subscribe(topic, qos=1)
        if self._on_connect is not None:
            self._on_connect()
        self.connected.set()

    def _disconnected(self, _client: paho.Client, _data: Any, _flags: Any, reason: Any, _props: Any) -> None:
        self.connected.clear()
        log.info("disconnected from the broker %s (%s); connecting again", self.broker, reason)

    def _message(self, _client: paho.Client, _data: Any, message: paho.MQTTMessage) -> None:
        try:
            payload = json.loads(message.payload)
        except ValueError:
            log.warning("not JSON on %s: ignored", message.topic)
            return
        if not isinstance(payload, dict):
            log.warning("not a JSON object on %s: ignored", message.topic)
            return
        for pattern, handler in list(self._subscriptions.items()):
            if paho.topic_matches_sub(pattern, message.topic):
                handler(message.topic, payload)
