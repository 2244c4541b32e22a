"""The G1's motion service release (`motion_switcher` RPC) on loopback DDS: client and simulated robot's service in one process."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from hw.dds import api_messages as api
from hw.dds import motion_switcher as ms
from hw.dds.session import DdsConfig, DdsSession
from tests.conftest import wait_for


@pytest.fixture
def robot(claim_dds_domain: Callable[[], int]) -> Iterator[tuple[DdsSession, ms.MotionSwitcherService]]:
    """A session with the robot's service answering from a thread, as the simulated robot's loop would."""
    session = DdsSession(DdsConfig(domain=claim_dds_domain(), interface="lo"))
    service = ms.MotionSwitcherService(session, mode="ai")
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            service.poll()
            time.sleep(0.002)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield session, service
    finally:
        stop.set()
        thread.join()
        session.close()


def test_the_active_mode_is_released_once(robot: tuple[DdsSession, ms.MotionSwitcherService]) -> None:
    session, service = robot
    assert ms.MotionSwitcherClient(session, timeout_s=2.0).check_mode() == "ai"
    assert ms.release_motion_service(session, wait_s=0.01, timeout_s=2.0) == "ai"
    assert service.mode == "" and service.counters.release_requests == 1
    assert ms.release_motion_service(session, wait_s=0.01, timeout_s=2.0) is None  # nothing active: nothing to release
    assert service.counters.release_requests == 1


def test_select_and_unknown_api_ids_answer_their_codes(robot: tuple[DdsSession, ms.MotionSwitcherService]) -> None:
    session, service = robot
    client = ms.MotionSwitcherClient(session, timeout_s=2.0)
    assert client.call(4242) == (ms.ERR_API_NOT_IMPLEMENTED, "")
    assert client.call(ms.API_ID_VERSION) == (ms.OK, "1.0.0.1")
    client.release_mode()
    client.select_mode("normal")
    assert client.check_mode() == "normal" and service.counters.unknown_requests == 1
    with pytest.raises(ms.MotionSwitcherError, match="answered SelectMode with code 7004"):
        client.select_mode("")


def test_a_mode_that_stays_active_is_named(robot: tuple[DdsSession, ms.MotionSwitcherService]) -> None:
    session, service = robot
    service._handle = lambda api_id, parameter: (ms.OK, '{"form": "0", "name": "ai"}')  # type: ignore[method-assign]
    with pytest.raises(ms.MotionSwitcherError, match=r"^the robot's high-level motion service 'ai' did not release after 2 attempts: "):
        ms.release_motion_service(session, attempts=2, wait_s=0.01, timeout_s=2.0)


def test_stale_and_foreign_responses_are_ignored(robot: tuple[DdsSession, ms.MotionSwitcherService]) -> None:
    session, _ = robot
    client = ms.MotionSwitcherClient(session, timeout_s=2.0)
    impostor = session.writer(ms.response_topic(), api.Response_, qos=ms._qos(reliable=True))
    assert client.check_mode() == "ai"  # discovery done
    for wrong_id, wrong_api in ((client._last_id, ms.CHECK_MODE), (client._last_id + 1, ms.RELEASE_MODE)):
        identity = api.RequestIdentity_(wrong_id, wrong_api)
        impostor.write(api.Response_(api.ResponseHeader_(identity, api.ResponseStatus_(0)), '{"name": ""}'))
    assert wait_for(lambda: client.check_mode() == "ai" and client.stale_responses == 2)  # a call sets aside what is not its answer


def test_no_service_is_one_line_naming_domain_and_interface(claim_dds_domain: Callable[[], int]) -> None:
    domain = claim_dds_domain()
    session = DdsSession(DdsConfig(domain=domain, interface="lo"))
    try:
        with pytest.raises(ms.MotionServiceNotFoundError) as raised:
            ms.release_motion_service(session, timeout_s=0.3)
        message = str(raised.value)
        assert "\n" not in message
        where = f"on DDS domain {domain}, interface 'lo' in 0.3 s"
        assert message.startswith(f"no answer from the robot's motion_switcher service (CheckMode) {where}")
    finally:
        session.close()
