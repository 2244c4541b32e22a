"""The request and response types of the robot's RPC services (`unitree_api::msg::dds_`) as Cyclone DDS types.

Type names and fields as in Unitree's public SDK (unitree_sdk2_python,
`unitree_sdk2py/idl/unitree_api/msg/dds_/`): every service (`motion_switcher`, ...) takes a
`Request_` on `rt/api/<service>/request` and answers a `Response_` on `rt/api/<service>/response`,
matched by `header.identity` (a client's unique id and the API id).
Needs the `g1` extra. No `from __future__ import annotations` here: cyclonedds reads the field
types from the annotations themselves.
"""

from dataclasses import dataclass, field

from hw.dds import EXTRA_HINT
from hw.errors import ConfigError

try:
    from cyclonedds.idl import IdlStruct, types
    from cyclonedds.idl import annotations as annotate
except ImportError as exc:  # one line naming the extra
    raise ConfigError(EXTRA_HINT) from exc

_MODULE = "unitree_api.msg.dds_"


@dataclass
@annotate.final
class RequestIdentity_(IdlStruct, typename=f"{_MODULE}.RequestIdentity_"):
    id: types.int64
    api_id: types.int64


@dataclass
@annotate.final
class RequestLease_(IdlStruct, typename=f"{_MODULE}.RequestLease_"):
    id: types.int64


@dataclass
@annotate.final
class RequestPolicy_(IdlStruct, typename=f"{_MODULE}.RequestPolicy_"):
    priority: types.int32
    noreply: bool


@dataclass
@annotate.final
class RequestHeader_(IdlStruct, typename=f"{_MODULE}.RequestHeader_"):
    identity: RequestIdentity_
    lease: RequestLease_
    policy: RequestPolicy_


@dataclass
@annotate.final
class Request_(IdlStruct, typename=f"{_MODULE}.Request_"):
    header: RequestHeader_
    parameter: str  # JSON
    binary: types.sequence[types.uint8] = field(default_factory=list)


@dataclass
@annotate.final
class ResponseStatus_(IdlStruct, typename=f"{_MODULE}.ResponseStatus_"):
    code: types.int32  # 0: done


@dataclass
@annotate.final
class ResponseHeader_(IdlStruct, typename=f"{_MODULE}.ResponseHeader_"):
    identity: RequestIdentity_  # the request's, echoed
    status: ResponseStatus_


@dataclass
@annotate.final
class Response_(IdlStruct, typename=f"{_MODULE}.Response_"):
    header: ResponseHeader_
    data: str  # JSON
    binary: types.sequence[types.uint8] = field(default_factory=list)
