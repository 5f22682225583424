"""Whether the gateway can listen where it is asked to, said in one sentence: an address is
checked before it is saved (PUT /api/settings/network, an imported settings file), and the
listening socket is opened before anything else starts (cart2d sim, cart2d serve). And where
it can then be reached (panel_urls)."""

from __future__ import annotations

import errno
import ipaddress
import socket
from collections.abc import Iterable

from cart2d.server import serving
from cart2d.server.guards import WILDCARD_BINDS, machine_addresses

_LOOPBACK_NAMES = {"localhost", "localhost.localdomain"}


class CannotListen(OSError):
    """The gateway cannot listen on this address and port; str() says why, in a sentence."""


def _canonical(text: str) -> str:
    return text.split("%", 1)[0].lower()


def _addresses_text() -> str:
    found = sorted(a for a in machine_addresses() if not a.startswith("fe80:"))
    return ", ".join(found) if found else "none found"


def address_problem(host: str) -> str | None:
    """None if this machine has `host` (an address of one of its interfaces, a name that resolves
    to one, loopback, or 0.0.0.0 / :: for every interface), else why not, in a sentence."""
    if host in WILDCARD_BINDS or host.lower() in _LOOPBACK_NAMES:
        return None
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError):
        return f"{host} is not an address and no name this machine can resolve"
    resolved = {_canonical(str(sockaddr[0])) for *_, sockaddr in infos}
    local = {_canonical(a) for a in machine_addresses()}
    if resolved & local or any(a.startswith("127.") or a == "::1" for a in resolved):
        return None
    return (
        f"{host} is not an address of this machine (it has {_addresses_text()}): use one of those, "
        "127.0.0.1 for this machine alone or 0.0.0.0 for every interface"
    )


def open_listener(host: str, port: int, backlog: int = serving.BACKLOG) -> socket.socket:
    """The gateway's listening socket on host:port (serving.listening_socket), or CannotListen
    with the reason in a sentence: the port in use, an address this machine does not have, a
    port that needs privileges."""
    problem = address_problem(host)
    if problem is not None:
        raise CannotListen(problem)
    try:
        return serving.listening_socket(host, port, backlog)
    except socket.gaierror as exc:
        raise CannotListen(f"{host} cannot be resolved: {exc.strerror}") from exc
    except OSError as exc:
        where = f"{host} port {port}"
        if exc.errno == errno.EADDRINUSE:
            message = f"{where} is in use (another cart2d, or another server): stop it or choose another port"
        elif exc.errno == errno.EADDRNOTAVAIL:
            message = f"{host} is not an address of this machine (it has {_addresses_text()})"
        elif exc.errno == errno.EACCES:
            message = f"{where}: ports below 1024 need administrator rights; choose one from 1024 to 65535"
        else:
            message = f"cannot listen on {where}: {exc.strerror or exc}"
        raise CannotListen(message) from exc


def _url(address: str, port: int) -> str:
    return f"http://[{address}]:{port}/" if ":" in address else f"http://{address}:{port}/"


def panel_urls(host: str, port: int, addresses: Iterable[str] | None = None) -> list[str]:
    """The panel's addresses for a gateway listening on host:port, this machine's first: bound
    to every interface (0.0.0.0, ::), 127.0.0.1 and this machine's other addresses (`addresses`,
    default every interface's), IPv6 ones for :: only and none that is link-local (they need
    the interface's name)."""
    if host not in WILDCARD_BINDS:
        return [_url(host, port)]
    ipv6 = host == "::"
    found = machine_addresses() if addresses is None else set(addresses)
    others = []
    for text in found:
        address = ipaddress.ip_address(text)
        if address.is_loopback or address.is_link_local or (address.version == 6 and not ipv6):
            continue
        others.append(address)
    others.sort(key=lambda a: (a.version, a))
    return [_url("127.0.0.1", port), *(_url(str(a), port) for a in others)]
