"""The instruction socket: its owner's alone, local only, bad messages dropped and counted, and no client can hold it up."""

from __future__ import annotations

import os
import re
import shutil
import socket
import stat
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from controller.inputs.instruction_socket import InstructionSocket, send_instruction
from controller.inputs.instructions import MAX_MESSAGE_BYTES, InstructionInbox
from hw.errors import ConfigError, InputDeviceError
from tests.conftest import wait_for


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    path = tmp_path / "run"
    path.mkdir(mode=0o700)
    return path


@pytest.fixture
def served(folder: Path) -> Iterator[tuple[InstructionSocket, InstructionInbox]]:
    inbox = InstructionInbox()
    with InstructionSocket(folder / "g1.sock", inbox) as server:
        yield server, inbox


def connect(path: Path) -> socket.socket:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(5.0)
    sock.connect(os.fspath(path))
    return sock


def reply_line(sock: socket.socket) -> str:
    data = b""
    while not data.endswith(b"\n"):
        chunk = sock.recv(4096)
        assert chunk, f"closed before a whole reply: {data!r}"
        data += chunk
    return data.decode().strip()


def socket_inodes() -> set[int]:
    """Inodes of this process's open sockets."""
    inodes = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except FileNotFoundError:  # the listing's own descriptor, gone already
            continue
        found = re.fullmatch(r"socket:\[(\d+)\]", target)
        if found:
            inodes.add(int(found.group(1)))
    return inodes


def table_inodes(name: str) -> set[int]:
    """Socket inodes of /proc/net/NAME (tcp, tcp6, udp, unix)."""
    lines = Path(f"/proc/net/{name}").read_text().splitlines()[1:]
    column = 6 if name == "unix" else 9
    return {int(line.split()[column]) for line in lines if len(line.split()) > column}


def test_the_socket_is_its_owners_alone_local_only_and_removed_at_close(folder: Path) -> None:
    path = folder / "g1.sock"
    before = socket_inodes()
    server = InstructionSocket(path, InstructionInbox())
    info = os.stat(path)
    assert stat.S_ISSOCK(info.st_mode) and stat.S_IMODE(info.st_mode) == 0o600 and info.st_uid == os.getuid()
    opened = socket_inodes() - before  # the listener and its wake-up pair: Unix sockets, none on a network
    assert opened and opened <= table_inodes("unix")
    assert not opened & (table_inodes("tcp") | table_inodes("tcp6") | table_inodes("udp") | table_inodes("udp6"))
    server.close()
    assert not path.exists()
    server.close()  # safe twice


@pytest.mark.skipif(os.getuid() != 0 or shutil.which("python3", path="/usr/bin") is None, reason="needs root to act as another user")
def test_another_user_cannot_connect(served: tuple[InstructionSocket, InstructionInbox]) -> None:
    server, _ = served
    probe = f"import socket; socket.socket(socket.AF_UNIX).connect({str(server.path)!r})"
    result = subprocess.run(["/usr/bin/python3", "-c", probe], user=65534, capture_output=True, text=True, timeout=30, cwd="/")
    assert result.returncode != 0 and "PermissionError" in result.stderr


def test_unsafe_or_taken_paths_are_refused_in_one_line(folder: Path, tmp_path: Path) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    with pytest.raises(ConfigError, match=r"can be written by others .*mode 777.*only you can write"):
        InstructionSocket(shared / "g1.sock", InstructionInbox())
    with pytest.raises(ConfigError, match="does not exist"):
        InstructionSocket(folder / "missing" / "g1.sock", InstructionInbox())
    (folder / "file").write_text("")
    with pytest.raises(ConfigError, match="exists and is not a socket"):
        InstructionSocket(folder / "file", InstructionInbox())
    with pytest.raises(ConfigError, match="a socket path holds 107"):
        InstructionSocket(folder / ("x" * 120), InstructionInbox())
    with InstructionSocket(folder / "g1.sock", InstructionInbox()), pytest.raises(ConfigError, match="another run listens"):
        InstructionSocket(folder / "g1.sock", InstructionInbox())


def test_a_stale_socket_of_an_ended_run_is_replaced(folder: Path) -> None:
    path = folder / "g1.sock"
    stale = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stale.bind(os.fspath(path))
    stale.close()  # its file stays, nobody listens
    with InstructionSocket(path, InstructionInbox()):
        assert stat.S_IMODE(os.stat(path).st_mode) == 0o600


def test_messages_get_one_reply_each_and_bad_ones_are_dropped_and_counted(served: tuple[InstructionSocket, InstructionInbox]) -> None:
    server, inbox = served
    with connect(server.path) as client:
        client.sendall(b"wave\n")
        instruction = inbox.next_pending(5.0)
        assert instruction is not None and instruction.text == "wave" and instruction.origin == "socket"
        inbox.settle(instruction, "running", "", "accepted: 1 clause: wave")  # as the control thread decides it
        assert reply_line(client) == "accepted: 1 clause: wave"
        client.sendall(b"walk \xff\xfe forward\n")
        assert reply_line(client).startswith("dropped: not UTF-8 text")
        client.sendall(b"a" * (MAX_MESSAGE_BYTES + 500) + b"\n")
        assert reply_line(client) == f"dropped: a message over {MAX_MESSAGE_BYTES} bytes without a newline"
        client.sendall(b"\n")
        assert reply_line(client).startswith("refused: empty instruction")
        client.sendall(b"turn left\n")  # the connection still serves
        assert (later := inbox.next_pending(5.0)) is not None and later.text == "turn left"
    assert inbox.dropped == {"malformed": 1, "oversized": 1}
    assert inbox.report(0.0)["dropped_messages"] == {"oversized": 1, "malformed": 1}


def test_a_client_that_stops_sending_still_gets_its_reply(served: tuple[InstructionSocket, InstructionInbox]) -> None:
    server, inbox = served
    with connect(server.path) as client:
        client.sendall(b"wave")  # no newline: its end is the message's
        client.shutdown(socket.SHUT_WR)
        instruction = inbox.next_pending(5.0)
        assert instruction is not None and instruction.text == "wave"
        inbox.settle(instruction, "refused", "a test", "refused: a test")
        assert reply_line(client) == "refused: a test"
        assert client.recv(10) == b""  # then it is closed


def test_stalled_silent_and_deaf_clients_hold_up_nothing(folder: Path) -> None:
    inbox = InstructionInbox()
    with InstructionSocket(folder / "g1.sock", inbox, max_clients=3) as server:
        stalled = connect(server.path)
        stalled.sendall(b"walk forw")  # half a message, then nothing
        deaf = connect(server.path)  # sends garbage without end and never reads its replies
        deaf.sendall(b"\xff\n" * 20000)
        assert wait_for(lambda: server.counters.unread_replies == 1)  # closed once its unread replies pile up
        assert inbox.dropped["malformed"] > 100
        with connect(server.path) as client:  # meanwhile every other client is served
            client.sendall(b"wave\n")
            instruction = inbox.next_pending(5.0)
            assert instruction is not None and instruction.text == "wave"
            start = time.perf_counter()
            inbox.settle(instruction, "running", "", "accepted: 1 clause: wave")  # the control thread's side never waits
            assert time.perf_counter() - start < 0.05
            assert reply_line(client) == "accepted: 1 clause: wave"
            silent = [connect(server.path) for _ in range(2)]  # more than max_clients: the longest silent one makes way
            assert wait_for(lambda: server.counters.evicted >= 1)
            assert stalled.recv(10) == b""
        for sock in (stalled, deaf, *silent):
            sock.close()
    assert server.counters.connections == 5


def test_tell_sends_one_instruction_and_returns_the_reply(served: tuple[InstructionSocket, InstructionInbox], folder: Path) -> None:
    server, inbox = served

    def control_thread() -> None:
        instruction = inbox.next_pending(5.0)
        assert instruction is not None
        inbox.settle(instruction, "running", "", f"accepted: 1 clause: {instruction.text}")

    thread = threading.Thread(target=control_thread)
    thread.start()
    assert send_instruction(server.path, "wave with your right hand") == "accepted: 1 clause: wave with your right hand"
    thread.join()
    with pytest.raises(InputDeviceError, match="no run listens on .*: start one with g1ctl run --instructions"):
        send_instruction(folder / "nobody.sock", "wave")
    with pytest.raises(ConfigError, match="one instruction a line"):
        send_instruction(server.path, "wave\nstop")
