"""A local Unix socket that takes instructions while the robot runs (`g1ctl run --instructions PATH`, `g1ctl tell`).

Newline-delimited UTF-8 messages in, one reply line out for each ("accepted: ...", "refused: ...",
"dropped: ..."). It listens on a filesystem path only, never on a network address: the socket is
created with mode 0600 in a directory only the user can write (anything else is refused in one
line), a peer of another user is turned away (its credentials, SO_PEERCRED), and `close` removes
the socket. One thread serves every client with non-blocking sockets: a client that sends garbage,
stops mid-message or never reads its replies costs that thread a bounded buffer, and is closed
when it overflows it; the control loop never touches a socket (replies are queued here). The
oldest silent client makes way when `max_clients` are connected.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import queue
import selectors
import socket
import stat
import struct
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from controller.inputs.instructions import InstructionInbox, LineFramer
from hw.errors import ConfigError, InputDeviceError

log = logging.getLogger(__name__)

MAX_PATH_BYTES = 107  # sun_path holds 108 bytes with its terminating zero
MAX_CLIENTS = 8
MAX_REPLY_BYTES = 65536  # replies a client has not read: beyond this it is closed
RECV_BYTES = 4096
JOIN_TIMEOUT_S = 1.0
CLIENT_TIMEOUT_S = 10.0  # `send_instruction`: how long it waits for the reply line


def check_socket_path(path: Path) -> None:
    """One line for a path the socket cannot be created at safely; a stale socket of an ended run is removed."""
    encoded = os.fsencode(path)
    if len(encoded) > MAX_PATH_BYTES:
        raise ConfigError(f"--instructions {path}: {len(encoded)} bytes, a socket path holds {MAX_PATH_BYTES} at most; use a shorter one")
    directory = path.parent.resolve()
    try:
        info = directory.stat()
    except FileNotFoundError:
        raise ConfigError(f"--instructions {path}: the directory {directory} does not exist (mkdir -m 700 {directory})") from None
    if not stat.S_ISDIR(info.st_mode):
        raise ConfigError(f"--instructions {path}: {directory} is not a directory")
    if info.st_uid != os.getuid() or info.st_mode & 0o022:
        raise ConfigError(
            f"--instructions {path}: {directory} can be written by others (owner uid {info.st_uid}, mode {stat.S_IMODE(info.st_mode):o}); "
            "put the socket in a directory only you can write, e.g. $XDG_RUNTIME_DIR or one made with mkdir -m 700"
        )
    if not os.path.lexists(path):
        return
    if not stat.S_ISSOCK(os.lstat(path).st_mode):
        raise ConfigError(f"--instructions {path}: the path exists and is not a socket; choose another path")
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
        try:
            probe.connect(os.fspath(path))
        except ConnectionRefusedError:
            os.unlink(path)  # a run that ended without removing it: nobody listens
            return
    raise ConfigError(f"--instructions {path}: another run listens on this socket; choose another path")


@dataclass(eq=False)
class _Client:
    sock: socket.socket
    framer: LineFramer = field(default_factory=LineFramer)
    out: bytearray = field(default_factory=bytearray)
    last_heard: float = field(default_factory=time.monotonic)
    awaiting: int = 0  # messages it sent whose reply has not been queued yet
    ended: bool = False  # it sent its last byte (shut its writing side): it stays for its replies


@dataclass
class SocketCounters:
    connections: int = 0
    other_users: int = 0  # peers of another user, turned away
    evicted: int = 0  # silent clients closed to make room
    unread_replies: int = 0  # clients closed because they did not read their replies


class InstructionSocket:
    """Listens at `path` and hands every message to `inbox`; usable with `with`, `close` safe twice."""

    def __init__(self, path: Path, inbox: InstructionInbox, max_clients: int = MAX_CLIENTS) -> None:
        check_socket_path(path)
        self.path = path
        self.inbox = inbox
        self.max_clients = max_clients
        self.counters = SocketCounters()
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        umask = os.umask(0o177)  # created 0600: nobody else may connect, even for an instant
        try:
            self._listener.bind(os.fspath(path))
        except OSError as exc:
            self._listener.close()
            raise ConfigError(f"--instructions {path}: cannot create the socket ({exc})") from exc
        finally:
            os.umask(umask)
        os.chmod(path, 0o600)
        self._inode = os.stat(path).st_ino
        self._listener.listen(max_clients)
        self._listener.setblocking(False)
        self._wake_read, self._wake_write = socket.socketpair()
        self._wake_read.setblocking(False)
        self._wake_write.setblocking(False)
        self._outgoing: queue.SimpleQueue[tuple[int, str]] = queue.SimpleQueue()
        self._clients: dict[int, _Client] = {}  # by file descriptor
        self._selector = selectors.DefaultSelector()
        self._selector.register(self._listener, selectors.EVENT_READ, "accept")
        self._selector.register(self._wake_read, selectors.EVENT_READ, "wake")
        self._stop = threading.Event()
        self._closed = False
        self._thread = threading.Thread(target=self._serve, name="instruction-socket", daemon=True)
        self._thread.start()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def report(self) -> dict[str, Any]:
        return {"path": str(self.path)} | vars(self.counters)

    # -- the server thread ------------------------------------------------------------------
    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                events = self._selector.select(timeout=0.5)
            except OSError as exc:  # the selector itself failed: nothing more can be served
                log.error("the instruction socket stops serving: %s", exc)
                return
            for key, mask in events:
                try:
                    if key.data == "accept":
                        self._accept()
                    elif key.data == "wake":
                        self._queue_replies()
                    else:
                        self._serve_client(key.fd, mask)
                except Exception as exc:  # one client's trouble never ends the server
                    log.error("instruction socket: %s", exc, exc_info=exc)
                    if isinstance(key.data, _Client):
                        self._drop_client(key.fd)

    def _accept(self) -> None:
        try:
            sock, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        uid = struct.unpack("3i", sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i")))[1]
        if uid != os.getuid():
            self.counters.other_users += 1
            log.warning("instruction socket: turned away a peer of uid %d", uid)
            sock.close()
            return
        if len(self._clients) >= self.max_clients:
            oldest = min(self._clients, key=lambda fd: self._clients[fd].last_heard)
            self.counters.evicted += 1
            self._drop_client(oldest)
        sock.setblocking(False)
        client = _Client(sock)
        self._clients[sock.fileno()] = client
        self._selector.register(sock, selectors.EVENT_READ, client)
        self.counters.connections += 1

    def _serve_client(self, fd: int, mask: int) -> None:
        client = self._clients.get(fd)
        if client is None:
            return
        if mask & selectors.EVENT_WRITE:
            self._flush(fd, client)
        if mask & selectors.EVENT_READ and fd in self._clients and not client.ended:
            try:
                data = client.sock.recv(RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                self._drop_client(fd)
                return
            arrived = time.perf_counter()
            client.last_heard = time.monotonic()
            if data:
                for message in client.framer.feed(data):
                    self._hand_on(fd, client, message, arrived)
                return
            last = client.framer.finish()  # it sent all it will (a last line may lack its newline); it stays for its replies
            if last is not None:
                self._hand_on(fd, client, last, arrived)
            client.ended = True
            self._watch(fd, client)

    def _hand_on(self, fd: int, client: _Client, message: bytes | None, arrived: float) -> None:
        """One framed message to the inbox (None: one dropped as oversized), its reply addressed back to `fd`."""

        def reply(line: str) -> None:
            self._outgoing.put((fd, line))
            with contextlib.suppress(BlockingIOError):
                self._wake_write.send(b"\0")

        client.awaiting += 1
        if message is LineFramer.OVERSIZED:
            self.inbox.drop("oversized", f"a message over {client.framer.max_bytes} bytes without a newline", reply)
        else:
            self.inbox.submit(message, "socket", reply, arrived)

    def _queue_replies(self) -> None:
        with contextlib.suppress(BlockingIOError):
            while self._wake_read.recv(RECV_BYTES):
                pass
        while True:
            try:
                fd, line = self._outgoing.get_nowait()
            except queue.Empty:
                return
            client = self._clients.get(fd)
            if client is None:  # it left before its reply
                continue
            client.out += line.encode() + b"\n"
            client.awaiting -= 1
            if len(client.out) > MAX_REPLY_BYTES:
                self.counters.unread_replies += 1
                self._drop_client(fd)
                continue
            self._watch(fd, client)

    def _watch(self, fd: int, client: _Client) -> None:
        """Listen to `client` for what it still may do: send (unless it ended), take replies (while some wait); a client
        with neither is closed."""
        events = (0 if client.ended else selectors.EVENT_READ) | (selectors.EVENT_WRITE if client.out else 0)
        if not events:
            if client.awaiting <= 0:
                self._drop_client(fd)
            else:
                with contextlib.suppress(KeyError, ValueError):
                    self._selector.unregister(client.sock)
            return
        try:
            self._selector.modify(client.sock, events, client)
        except KeyError:
            self._selector.register(client.sock, events, client)

    def _flush(self, fd: int, client: _Client) -> None:
        try:
            sent = client.sock.send(client.out)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop_client(fd)
            return
        del client.out[:sent]
        if not client.out:
            self._watch(fd, client)

    def _drop_client(self, fd: int) -> None:
        client = self._clients.pop(fd, None)
        if client is None:
            return
        with contextlib.suppress(KeyError, ValueError):
            self._selector.unregister(client.sock)
        client.sock.close()

    # -- closing ----------------------------------------------------------------------------
    def close(self) -> None:
        """Stop serving, close every client, remove the socket (only if it is still this one's)."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        with contextlib.suppress(OSError):
            self._wake_write.send(b"\0")
        self._thread.join(timeout=JOIN_TIMEOUT_S)
        if self._thread.is_alive():
            log.warning("the instruction socket's thread did not stop within %.1f s", JOIN_TIMEOUT_S)
        else:  # the last replies (instructions cancelled as the run ended), once, without waiting
            self._queue_replies()
            for client in list(self._clients.values()):
                with contextlib.suppress(OSError):
                    client.sock.send(client.out)
        for fd in list(self._clients):
            self._drop_client(fd)
        self._selector.close()
        for sock in (self._listener, self._wake_read, self._wake_write):
            sock.close()
        with contextlib.suppress(FileNotFoundError):
            if os.stat(self.path).st_ino == self._inode:
                os.unlink(self.path)


def send_instruction(path: Path, text: str, timeout: float = CLIENT_TIMEOUT_S) -> str:
    """Send one instruction to the run listening at `path` and return its reply line (`g1ctl tell`)."""
    if "\n" in text or "\r" in text:
        raise ConfigError("one instruction a line: the text holds a line break")
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.settimeout(timeout)
        try:
            sock.connect(os.fspath(path))
        except (FileNotFoundError, ConnectionRefusedError) as exc:
            raise InputDeviceError(f"no run listens on {path}: start one with g1ctl run --instructions {path}") from exc
        except OSError as exc:
            if exc.errno == errno.EACCES:
                raise InputDeviceError(f"{path}: permission denied (the socket is its owner's only)") from exc
            raise InputDeviceError(f"cannot connect to {path}: {exc}") from exc
        sock.sendall(text.encode("utf-8", errors="surrogateescape") + b"\n")
        reply = bytearray()
        deadline = time.monotonic() + timeout
        while b"\n" not in reply:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise InputDeviceError(f"no reply from the run on {path} within {timeout:g} s")
            sock.settimeout(remaining)
            try:
                data = sock.recv(RECV_BYTES)
            except TimeoutError:
                continue
            if not data:
                raise InputDeviceError(f"the run on {path} closed the connection before replying")
            reply += data
    return reply.split(b"\n", 1)[0].decode("utf-8", errors="replace")
