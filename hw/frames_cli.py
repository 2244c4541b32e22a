"""`g1ctl hw frame encode|decode`: the everyday tool when reading a bus capture. Pure functions."""

from __future__ import annotations

from typing import Any

from hw.errors import ConfigError
from hw.protocols import mit
from hw.protocols import unitree_hg as hg
from hw.protocols import unitree_rs485 as rs485

PROTOCOLS = ("mit", "unitree-rs485", "unitree-hg")


def encode_frame(
    protocol: str, ranges: mit.MitRanges | None, motor_id: int, mode: int, values: dict[str, float], mode_machine: int = 0
) -> bytes:
    """Data bytes of a command with motor-side values as they go on the wire (unitree-hg: a whole `LowCmd_`, motor `motor_id` set)."""
    q, dq, tau, kp, kd = (values.get(k, 0.0) for k in ("position", "velocity", "torque", "kp", "kd"))
    if protocol == "unitree-hg":
        try:
            return hg.encode_motor_command(motor_id, mode, q, dq, tau, kp, kd, mode_machine)
        except hg.FrameError as exc:
            raise ConfigError(str(exc)) from exc
    if protocol == "mit":
        if ranges is None:
            raise ConfigError("MIT frames need --model (ranges per motor model, see configs/motors.yaml)")
        return mit.encode_command(ranges, q, dq, kp, kd, tau)
    if protocol == "unitree-rs485":
        try:
            return rs485.encode_command(motor_id, mode, tau, dq, q, kp, kd)
        except ValueError as exc:
            raise ConfigError(str(exc)) from exc
    raise ConfigError(f"unknown protocol '{protocol}' (valid: {', '.join(PROTOCOLS)})")


def decode_frame(protocol: str, hex_text: str, ranges: mit.MitRanges | None, reply: str | None) -> dict[str, Any]:
    """Fields of a frame as plain data. MIT: 8 bytes are a command unless `reply` names a variant; 6 bytes a basic reply."""
    try:
        data = bytes.fromhex(hex_text.replace(" ", "").replace(":", ""))
    except ValueError as exc:
        raise ConfigError(f"'{hex_text}' is not hex bytes (like 7fff7ff0000007ff)") from exc
    if protocol == "mit":
        if data in mit.SPECIAL_FRAMES:
            return {"kind": "special", "special": mit.SPECIAL_FRAMES[data]}
        if ranges is None:
            raise ConfigError("MIT frames need --model (ranges per motor model, see configs/motors.yaml)")
        variant = reply or ("basic" if len(data) == 6 else None)
        try:
            if variant is None:
                c = mit.decode_command(ranges, data)
                return {"kind": "command", "position": c.position, "velocity": c.velocity, "kp": c.kp, "kd": c.kd, "torque": c.torque}
            if variant not in mit.REPLY_VARIANTS:
                raise ConfigError(f"unknown reply variant '{variant}' (valid: {', '.join(mit.REPLY_VARIANTS)})")
            r = mit.decode_reply(ranges, variant, data)  # type: ignore[arg-type]
        except ValueError as exc:
            raise ConfigError(str(exc)) from exc
        return {"kind": f"reply ({variant})", **{k: v for k, v in vars(r).items() if v is not None}}
    if protocol == "unitree-hg":
        try:
            if len(data) == hg.LOW_CMD_SIZE:
                return hg.low_cmd_fields(hg.unpack_low_cmd(data))
            if len(data) == hg.LOW_STATE_SIZE:
                return hg.low_state_fields(hg.unpack_low_state(data))
        except hg.FrameError as exc:
            raise ConfigError(str(exc)) from exc
        sizes = f"LowCmd_ ({hg.LOW_CMD_SIZE} bytes) or LowState_ ({hg.LOW_STATE_SIZE})"
        raise ConfigError(f"a unitree-hg message is {sizes}, got {len(data)} bytes")
    if protocol == "unitree-rs485":
        try:
            if data[:2] == rs485.COMMAND_HEADER:
                frame = rs485.decode_command(data)
                c = frame.command
                fields = {"torque": c.torque, "speed": c.velocity, "position": c.position, "kp": c.kp, "kd": c.kd}
                return {"kind": "command", "motor_id": frame.motor_id, "mode": frame.mode, **fields}
            rep = rs485.decode_reply(data)
        except rs485.FrameError as exc:
            raise ConfigError(str(exc)) from exc
        return {"kind": "reply", **vars(rep), "error": rep.error}
    raise ConfigError(f"unknown protocol '{protocol}' (valid: {', '.join(PROTOCOLS)})")
