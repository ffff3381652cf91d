"""Whether a host name or address (deik view's --host) can be served on from this machine,
decided at once: a malformed address, a name that cannot be looked up, or another machine's
address would otherwise keep the server trying port after port."""

from __future__ import annotations

import contextlib
import ipaddress
import re
import socket
import threading

from deik.errors import InputError

LOOKUP_SECONDS = 5.0  # how long a host name may take to look up


def check_host(host: str, timeout: float = LOOKUP_SECONDS) -> None:
    """InputError naming --host unless `host` is an address of this machine that a server can
    bind to (looked up within `timeout` seconds)."""
    if re.fullmatch(r"[0-9.]+", host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise InputError(f"--host {host!r} is not an IPv4 address (four numbers from 0 to 255)") from None
    found: list = []
    lookup = threading.Thread(target=lambda: found.append(_addresses(host)), daemon=True)
    lookup.start()
    lookup.join(timeout)
    if not found:
        raise InputError(f"--host {host!r}: no answer looking it up within {timeout:g} s; give an IP address")
    if not found[0]:
        raise InputError(f"--host {host!r}: no such host name; give an IP address such as 127.0.0.1")
    for family, address in found[0]:
        with contextlib.suppress(OSError), socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((address, 0))
            return
    raise InputError(
        f"--host {host!r} is not an address of this machine; use 127.0.0.1 (this machine only) or 0.0.0.0 (every "
        "network it is on)"
    )


def _addresses(host: str) -> list[tuple[int, str]]:
    """(family, address) of each address `host` names; none when it cannot be looked up."""
    try:
        return [(info[0], info[4][0]) for info in socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)]
    except (OSError, UnicodeError):
        return []
