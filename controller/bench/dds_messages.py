"""The raw reference of `g1ctl bench dds`: messages of the robot's sizes and nothing else, as Cyclone DDS types.

`RawCmd_` serializes to 1004 bytes and `RawState_` to 2092, the CDR sizes of `LowCmd_` and
`LowState_`: a byte array each, which Cyclone's Python serializer handles in one piece. No
`from __future__ import annotations` here: cyclonedds reads the field types from the annotations.
"""

from dataclasses import dataclass

from hw.dds import EXTRA_HINT
from hw.dds.cdr import LOW_CMD_BODY, LOW_STATE_BODY
from hw.errors import ConfigError

try:
    from cyclonedds.idl import IdlStruct, types
    from cyclonedds.idl import annotations as annotate
except ImportError as exc:  # one line naming the extra
    raise ConfigError(EXTRA_HINT) from exc


@dataclass
@annotate.final
class RawCmd_(IdlStruct, typename="g1ctl.bench.RawCmd_"):
    data: types.array[types.uint8, LOW_CMD_BODY]


@dataclass
@annotate.final
class RawState_(IdlStruct, typename="g1ctl.bench.RawState_"):
    data: types.array[types.uint8, LOW_STATE_BODY]


def raw_cmd(cdr_body: bytes) -> RawCmd_:
    return RawCmd_(cdr_body)


def raw_state(cdr_body: bytes) -> RawState_:
    return RawState_(cdr_body)
