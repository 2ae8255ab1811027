"""CURVE authentication and encryption of the component sockets (ZeroMQ's CurveZMQ, pyzmq's ``zmq.auth``).

``cosim keys DIR`` writes a key directory:

- ``server.key_secret`` and ``clients/`` (the public keys of the clients the server accepts): what the
  machine that serves a component needs;
- ``client.key_secret`` and ``server.key`` (the server's public key): what the coupler's machine needs;
- ``server.key`` and ``client.key``: the two public keys (``clients/client.key`` is a copy of the latter).

``cosim serve ENTRY --bind tcp://HOST:PORT --curve DIR`` serves with the server's key and accepts only the
clients in ``DIR/clients`` (a ZAP handler, ``zmq.auth.thread.ThreadAuthenticator``, started before the bind); the scene names the
component by ``address`` and ``curve = DIR``. A client whose key the server does not list gets no reply: its
handshake fails, which the coupler sees on its socket's monitor and reports at once.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import zmq
import zmq.auth
from zmq.utils.monitor import recv_monitor_message

from cosim.errors import ComponentError, CosimError

SERVER, CLIENT, CLIENTS = "server", "client", "clients"
# a refused client key (AUTH), a peer that speaks another mechanism (PROTOCOL), a server key that is not the
# server's (NO_DETAIL: the server cannot read the client's hello and drops it)
FAILED = (zmq.EVENT_HANDSHAKE_FAILED_AUTH | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
          | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)


def make_keys(directory: str | Path) -> list[Path]:
    """A server and a client key pair in ``directory`` (created; never overwritten), the client authorised."""
    directory = Path(directory)
    taken = [directory / f"{name}.key{suffix}" for name in (SERVER, CLIENT) for suffix in ("", "_secret")
             if (directory / f"{name}.key{suffix}").exists()]
    if taken:
        raise CosimError(f"'{taken[0]}' exists: keys are never overwritten (choose another directory)")
    (directory / CLIENTS).mkdir(parents=True, exist_ok=True)
    written = []
    mask = os.umask(0o077)       # the secrets are never readable by others, not even for a moment
    try:
        for name in (SERVER, CLIENT):
            public, secret = zmq.auth.create_certificates(str(directory), name)
            written += [Path(public), Path(secret)]
    finally:
        os.umask(mask)
    written.append(Path(shutil.copy(directory / f"{CLIENT}.key", directory / CLIENTS / f"{CLIENT}.key")))
    for path in written:
        path.chmod(0o600 if path.name.endswith("_secret") else 0o644)
    return written


def _load(path: Path, secret: bool, what: str) -> tuple[bytes, bytes | None]:
    """A key file's public and secret keys, each checked (40 characters of Z85, 32 bytes); a secret key file
    must be readable by its owner alone, as ssh asks of its keys."""
    if not path.is_file():
        raise CosimError(f"CURVE key '{path}' does not exist ({what}; `cosim keys DIR` makes the key directory)")
    if secret and path.stat().st_mode & 0o077:
        raise CosimError(f"CURVE secret key '{path}' is readable by others (mode {path.stat().st_mode & 0o777:o}): "
                         f"`chmod 600 {path}`, or make new keys")
    try:
        public, secret_key = zmq.auth.load_certificate(str(path))
    except (OSError, ValueError) as exc:
        raise CosimError(f"CURVE key '{path}' cannot be read: {exc}") from None
    if secret and secret_key is None:
        raise CosimError(f"CURVE key '{path}' holds no secret key")
    for name, key in (("public-key", public), ("secret-key", secret_key)):
        if key is not None and not _is_key(key):
            raise CosimError(f"CURVE key '{path}': its {name} is not a key ({len(key)} characters; a CURVE key is "
                             "40 characters of Z85, as `cosim keys` writes it)")
    return public, secret_key


def _is_key(key: bytes) -> bool:
    from zmq.utils import z85
    try:
        return len(key) == 40 and len(z85.decode(key)) == 32
    except (ValueError, KeyError, TypeError):
        return False


def check_client_keys(directory: str | Path) -> None:
    """Raise naming the file if ``directory`` lacks what a client needs (its secret key, the server's public)."""
    directory = Path(directory)
    _load(directory / f"{CLIENT}.key_secret", True, "the client's secret key")
    _load(directory / f"{SERVER}.key", False, "the server's public key")


def start_authenticator(directory: str | Path) -> Any:
    """The ZAP handler of this process's sockets, accepting only the clients in ``directory/clients``; started
    (stop it when the socket closes). It must run before a CURVE server socket takes connections."""
    from zmq.auth.thread import ThreadAuthenticator
    clients = Path(directory) / CLIENTS
    if not clients.is_dir() or not any(clients.glob("*.key")):
        raise CosimError(f"CURVE client directory '{clients}' lists no client key (*.key)")
    authenticator = ThreadAuthenticator(zmq.Context.instance())
    authenticator.start()
    authenticator.configure_curve(domain="*", location=str(clients))
    return authenticator


def curve_server(socket: zmq.Socket, directory: str | Path) -> None:
    """Make ``socket`` a CURVE server with ``directory``'s server key (before it binds)."""
    public, secret = _load(Path(directory) / f"{SERVER}.key_secret", True, "the server's secret key")
    socket.curve_secretkey = secret
    socket.curve_publickey = public
    socket.curve_server = True


def connect_with_curve(socket: zmq.Socket, directory: str | Path) -> zmq.Socket:
    """Make ``socket`` a CURVE client with ``directory``'s client key and server public key; returns a monitor
    socket that reports a failed handshake (see ``handshake_failure``). Call before ``connect``."""
    directory = Path(directory)
    public, secret = _load(directory / f"{CLIENT}.key_secret", True, "the client's secret key")
    server, _ = _load(directory / f"{SERVER}.key", False, "the server's public key")
    socket.curve_secretkey = secret
    socket.curve_publickey = public
    socket.curve_serverkey = server
    return watch_handshake(socket)


def watch_handshake(socket: zmq.Socket) -> zmq.Socket:
    """A monitor socket of ``socket``'s failed handshakes (see ``handshake_failure``); call before ``connect``."""
    return socket.get_monitor_socket(FAILED)


def handshake_failure(monitor: zmq.Socket, component: str, endpoint: str, directory: str) -> None:
    """Raise a named error if the handshake with the server failed: with CURVE (``directory``), the server refused
    this client's key, its key is not the one in the key directory, or it does not speak CURVE; without, the
    server speaks CURVE."""
    while monitor.poll(0):
        event = recv_monitor_message(monitor)["event"]
        if not directory:
            raise ComponentError(component, f"the handshake with {endpoint} failed: the server speaks CURVE (`cosim "
                                            "serve --curve`); set the component's curve to a key directory from "
                                            "`cosim keys` that the server lists")
        if event & zmq.EVENT_HANDSHAKE_FAILED_AUTH:
            raise ComponentError(component, f"the server at {endpoint} refused this client's CURVE key "
                                            f"('{directory}/{CLIENT}.key' is not among its clients)")
        if event & zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL:
            raise ComponentError(component, f"the CURVE handshake with {endpoint} failed: the server does not speak "
                                            "CURVE (serve it with `cosim serve --curve DIR`)")
        raise ComponentError(component, f"the CURVE handshake with {endpoint} failed: '{directory}/{SERVER}.key' is "
                                        "not the server's public key")
