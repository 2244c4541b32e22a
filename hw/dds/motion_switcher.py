"""Release the G1's high-level motion service before low-level control: the `motion_switcher` RPC over DDS.

A G1 boots with a high-level controller active (the "ai" locomotion mode) that drives the
motors itself; a host's `rt/lowcmd` must not fight it, so the host asks the robot's
`motion_switcher` service which mode is active (CheckMode) and releases it (ReleaseMode)
until none is. `MotionSwitcherService` is the robot's side, for the simulated G1.

The facts, from Unitree's public SDK (read, not used: unitree_sdk2_python
`unitree_sdk2py/comm/motion_switcher/`, `unitree_sdk2py/rpc/`, `core/channel_name.py`,
`example/g1/low_level/g1_low_level_example.py`; unitree_sdk2
`include/unitree/robot/b2/motion_switcher/`):

- RPC: a `Request_` on `rt/api/<service>/request`, the `Response_` on `rt/api/<service>/response`
  echoing the request's identity (id, api_id); parameters and answers are JSON strings.
- `motion_switcher` API ids: CheckMode 1001 (answers {"form": "0", "name": "ai"}; an empty name:
  nothing active), SelectMode 1002 ({"name": ...}), ReleaseMode 1003, SetSilent 1004, GetSilent
  1005 ({"silent": bool}); the internal API id 1 answers the API version, "1.0.0.1".
- Status codes: 0 done, 3203 API not implemented (server), 7004 mode name invalid.
- Bring-up: CheckMode; while a name is active: ReleaseMode, wait (1 s in the Python example,
  5 s in the C++ one), CheckMode again. The examples give each call a 5 s timeout.
- QoS: Cyclone's defaults (writers reliable, readers best effort). Here writers are reliable and
  readers best effort (they match any writer) with a history deep enough to keep every request.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from hw.dds.session import DdsSession
from hw.errors import HardwareFault

if TYPE_CHECKING:
    from hw.dds import api_messages

SERVICE = "motion_switcher"
API_VERSION = "1.0.0.1"
API_ID_VERSION = 1  # the RPC's internal "which API version" call
CHECK_MODE, SELECT_MODE, RELEASE_MODE, SET_SILENT, GET_SILENT = 1001, 1002, 1003, 1004, 1005
OK = 0
ERR_API_NOT_IMPLEMENTED = 3203
ERR_MODE_NAME = 7004
_NAMES = {CHECK_MODE: "CheckMode", SELECT_MODE: "SelectMode", RELEASE_MODE: "ReleaseMode", SET_SILENT: "SetSilent", GET_SILENT: "GetSilent"}
_DEPTH = 32  # requests and answers kept until taken: far more than one poll sees
_RESEND_S = 0.5  # an unanswered request is sent again (same id) after this long: a best-effort reader may miss one


def request_topic(service: str = SERVICE) -> str:
    return f"rt/api/{service}/request"


def response_topic(service: str = SERVICE) -> str:
    return f"rt/api/{service}/response"


def _qos(reliable: bool) -> Any:
    from cyclonedds.core import Policy, Qos  # noqa: PLC0415 - the optional extra

    reliability = Policy.Reliability.Reliable(max_blocking_time=100_000_000) if reliable else Policy.Reliability.BestEffort
    return Qos(reliability, Policy.History.KeepLast(_DEPTH))


class MotionSwitcherError(HardwareFault):
    """The motion service answered, but not as needed (an error code, a mode that stays active)."""


class MotionServiceNotFoundError(MotionSwitcherError):
    """No answer from the robot's motion service at all."""


class MotionSwitcherClient:
    """The host's end of `motion_switcher` on a `DdsSession` (the link's own: one participant per host)."""

    def __init__(self, session: DdsSession, timeout_s: float = 1.0) -> None:
        from hw.dds import api_messages as api  # noqa: PLC0415 - cyclonedds only here

        self._api = api
        self.session = session
        self.timeout_s = timeout_s
        self._requests = session.writer(request_topic(), api.Request_, qos=_qos(reliable=True))
        self._responses = session.reader(response_topic(), api.Response_, qos=_qos(reliable=False))
        self._last_id = 0
        self.stale_responses = 0  # answers to other requests (older ones, other clients): ignored

    def _new_id(self) -> int:
        """Unique and increasing: the SDK's monotonic nanoseconds, never repeated by this client."""
        self._last_id = max(self._last_id + 1, time.monotonic_ns())
        return self._last_id

    def _service_found(self) -> bool:
        return bool(self._requests.get_matched_subscriptions()) and bool(self._responses.get_matched_publications())

    def call(self, api_id: int, parameter: dict[str, Any] | None = None) -> tuple[int, str]:
        """The status code and data of one request; `MotionServiceNotFoundError` when nothing answers in time."""
        api = self._api
        identity = api.RequestIdentity_(self._new_id(), api_id)
        header = api.RequestHeader_(identity, api.RequestLease_(0), api.RequestPolicy_(0, False))
        request = api.Request_(header, json.dumps(parameter or {}))
        deadline = time.monotonic() + self.timeout_s
        next_send = 0.0  # send once the service is discovered both ways: a request before that is lost
        while (now := time.monotonic()) < deadline:
            if now >= next_send and self._service_found():
                self._requests.write(request)
                next_send = now + _RESEND_S
            for response in self._responses.take(N=_DEPTH):
                if not isinstance(response, api.Response_):
                    continue  # a writer leaving sends a sample without data
                answered = response.header.identity
                if answered.id == identity.id and answered.api_id == api_id:
                    return int(response.header.status.code), str(response.data)
                self.stale_responses += 1
            time.sleep(0.002)
        cfg = self.session.cfg
        raise MotionServiceNotFoundError(
            f"no answer from the robot's {SERVICE} service ({_NAMES.get(api_id, f'api {api_id}')}) on DDS domain {cfg.domain}, "
            f"interface '{cfg.interface}' in {self.timeout_s:g} s: check that the robot is powered and booted, the cable is in, "
            "and the domain and interface are the robot's"
        )

    def _checked(self, api_id: int, parameter: dict[str, Any] | None = None) -> str:
        code, data = self.call(api_id, parameter)
        if code != OK:
            raise MotionSwitcherError(f"the robot's {SERVICE} answered {_NAMES[api_id]} with code {code}")
        return data

    def check_mode(self) -> str:
        """The active high-level mode's name ("ai", "normal", ...), "" when none is: low-level control is free."""
        data = self._checked(CHECK_MODE)
        try:
            name = json.loads(data)["name"]
        except (ValueError, KeyError, TypeError) as exc:
            raise MotionSwitcherError(f"the robot's {SERVICE} answered CheckMode with {data!r}, not {{'name': ...}}") from exc
        return str(name)

    def release_mode(self) -> None:
        self._checked(RELEASE_MODE)

    def select_mode(self, name: str) -> None:
        """Hand the motors back to a high-level mode (the SDK's example selects "ai")."""
        self._checked(SELECT_MODE, {"name": name})


def release_motion_service(session: DdsSession, attempts: int = 5, wait_s: float = 1.0, timeout_s: float = 5.0) -> str | None:
    """Release the robot's high-level mode as the SDK's bring-up does; its name, None if none was active.

    `timeout_s` per call, as the SDK's examples set it: a robot busy releasing may answer late.
    """
    client = MotionSwitcherClient(session, timeout_s)
    name = client.check_mode()  # no answer here: the service is not there at all, and that error says so
    if not name:
        return None
    problem = f"CheckMode still reports '{name}'"
    for _ in range(attempts):
        try:
            client.release_mode()
        except MotionSwitcherError as exc:  # busy, or slow to answer: the SDK waits and checks again
            problem = str(exc)
        time.sleep(wait_s)
        try:
            active = client.check_mode()
        except MotionSwitcherError as exc:
            problem = str(exc)
            continue
        if not active:
            return name
        problem = f"CheckMode still reports '{active}'"
    raise MotionSwitcherError(f"the robot's high-level motion service '{name}' did not release after {attempts} attempts: {problem}")


@dataclass
class MotionServiceCounters:
    requests: int = 0
    check_requests: int = 0
    release_requests: int = 0
    select_requests: int = 0
    unknown_requests: int = 0  # answered ERR_API_NOT_IMPLEMENTED


class MotionSwitcherService:
    """The robot's end, for the simulated G1: `poll()` answers what arrived; `mode` is the active mode ("" released)."""

    def __init__(self, session: DdsSession, mode: str = "ai") -> None:
        from hw.dds import api_messages as api  # noqa: PLC0415 - cyclonedds only here

        self._api = api
        self.mode = mode
        self.silent = False
        self.counters = MotionServiceCounters()
        self._requests = session.reader(request_topic(), api.Request_, qos=_qos(reliable=False))
        self._responses = session.writer(response_topic(), api.Response_, qos=_qos(reliable=True))

    def poll(self) -> int:
        """Answer every request waiting; how many there were. Under a microsecond when none is."""
        answered = 0
        for request in self._requests.take(N=_DEPTH):
            if isinstance(request, self._api.Request_):
                self._answer(request)
                answered += 1
        return answered

    def _answer(self, request: api_messages.Request_) -> None:
        api = self._api
        self.counters.requests += 1
        code, data = self._handle(int(request.header.identity.api_id), request.parameter)
        if request.header.policy.noreply:
            return
        identity = api.RequestIdentity_(request.header.identity.id, request.header.identity.api_id)
        self._responses.write(api.Response_(api.ResponseHeader_(identity, api.ResponseStatus_(code)), data))

    def _handle(self, api_id: int, parameter: str) -> tuple[int, str]:
        if api_id == CHECK_MODE:
            self.counters.check_requests += 1
            return OK, json.dumps({"form": "0", "name": self.mode})
        if api_id == RELEASE_MODE:
            self.counters.release_requests += 1
            self.mode = ""
            return OK, ""
        if api_id == SELECT_MODE:
            self.counters.select_requests += 1
            name = _json_field(parameter, "name")
            if not isinstance(name, str) or not name:
                return ERR_MODE_NAME, ""
            self.mode = name
            return OK, ""
        if api_id == SET_SILENT:
            self.silent = bool(_json_field(parameter, "silent"))
            return OK, ""
        if api_id == GET_SILENT:
            return OK, json.dumps({"silent": self.silent})
        if api_id == API_ID_VERSION:
            return OK, API_VERSION
        self.counters.unknown_requests += 1
        return ERR_API_NOT_IMPLEMENTED, ""


def _json_field(parameter: str, key: str) -> Any:
    try:
        loaded = json.loads(parameter)
    except ValueError:
        return None
    return loaded.get(key) if isinstance(loaded, dict) else None
