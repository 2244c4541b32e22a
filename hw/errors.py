"""One exception tree for the whole stack.

Every error a user can cause or meet derives from `G1Error`; subclasses also derive
from the matching built-in so callers can catch what they expect (`FileNotFoundError`,
`ValueError`, `ConnectionError`). Messages say what is wrong and what to check.
"""

from __future__ import annotations


class G1Error(Exception):
    """Root of every error raised by the stack."""


class ConfigError(G1Error, ValueError):
    """A YAML file or a config value is invalid (unknown key, wrong shape, bad value)."""


class AssetError(G1Error, FileNotFoundError):
    """A model or policy file is missing, corrupt or cannot be fetched."""


class PolicyError(G1Error, ValueError):
    """An ONNX policy does not match its configuration (inputs, outputs, joint names)."""


class InputDeviceError(G1Error, ConnectionError):
    """A command input device (gamepad, keyboard) is absent or stopped answering."""


class BusError(G1Error, ConnectionError):
    """A CAN bus or serial port cannot be opened or stopped working."""


class MotorNotFoundError(G1Error, ConnectionError):
    """Configured motors did not answer at configure time."""


class HardwareFault(G1Error, RuntimeError):
    """A latched safety fault: the robot is damped until an explicit re-arm."""


class EmulatorError(G1Error, RuntimeError):
    """A firmware emulator of simulated hardware died: its bus no longer answers like the motors would."""


class LifecycleError(G1Error, RuntimeError):
    """A lifecycle transition that is not allowed from the current state."""


class RunAborted(G1Error, RuntimeError):
    """An exception ended a run after it started; its report was written first."""


class NotConfirmed(G1Error, RuntimeError):
    """An operation that needs a person's confirmation (setting an encoder zero) did not get it: nothing was sent."""
