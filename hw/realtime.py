"""Real-time scheduling for the process that runs the 500 Hz bus cycle.

Under the default time-sharing scheduler a 2 ms cycle is late whenever another task
holds the core; SCHED_FIFO lets the control threads preempt ordinary work, the way
ros2_control's `thread_priority` and Unitree's deploy scripts run. Memory is locked
(mlockall) so that no page fault stalls a cycle: on the development machine that removed
the bursts of 2-3 ms cycles that SCHED_FIFO alone left. Call it before any bus thread
starts: threads inherit the policy. It needs CAP_SYS_NICE and CAP_IPC_LOCK (root, or
`rtprio` and `memlock` lines in /etc/security/limits.conf); without them the run goes on
and the returned report says what was not granted. Pinning to one CPU (`cpu`) is the
other half of the usual recipe (with that CPU kept free of other work, e.g. `isolcpus`):
a cycle never migrates, and its threads hand frames to each other without cross-CPU
wake-ups. The third is the CPU's idle latency (the kernel's PM QoS, `/dev/cpu_dma_latency`
held at 0 while the process runs): between 2 ms cycles an idle CPU otherwise sleeps deep
enough to lose its caches, and every cycle's code then runs several times slower than warm
(measured here: a `LowState_` CRC check 4 us warm, 21 us after 1.7 ms asleep).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import dataclasses
import logging
import os
import sys
from dataclasses import dataclass

from hw.errors import ConfigError

log = logging.getLogger(__name__)

MAX_PRIORITY = 99
MCL_CURRENT, MCL_FUTURE = 1, 2  # <sys/mman.h> on Linux
PM_QOS_CPU_LATENCY = "/dev/cpu_dma_latency"  # write an int32 of microseconds, keep it open (Linux PM QoS)


@dataclass(frozen=True)
class Scheduling:
    """What the process runs under after `request_realtime`."""

    policy: str
    priority: int
    note: str = ""
    cpu: int | None = None
    idle_latency_held: bool = False  # PM QoS: the CPU does not sleep deep between cycles

    def describe(self) -> str:
        text = f"{self.policy} {self.priority}" if self.policy == "SCHED_FIFO" else self.policy
        if self.cpu is not None:
            text += f", pinned to CPU {self.cpu}"
        if self.idle_latency_held:
            text += ", CPU idle latency held at 0"
        return f"{text} ({self.note})" if self.note else text


def request_realtime(priority: int, cpu: int | None = None) -> Scheduling:
    """Switch this process to SCHED_FIFO at `priority` (1-99; 0 keeps normal scheduling)
    and, with `cpu`, pin it to that CPU."""
    if not 0 <= priority <= MAX_PRIORITY:
        raise ConfigError(f"real-time priority {priority} is out of range: use 1-{MAX_PRIORITY}, or 0 for normal scheduling")
    if cpu is not None:
        pin_to_cpu(cpu)
    scheduling = _set_policy(priority)
    return dataclasses.replace(scheduling, cpu=cpu, idle_latency_held=scheduling.policy == "SCHED_FIFO" and _hold_idle_latency())


def pin_to_cpu(cpu: int) -> None:
    """Run this thread, and every thread it starts from now on, on `cpu` only."""
    allowed = sorted(os.sched_getaffinity(0))
    if cpu not in allowed:
        raise ConfigError(f"CPU {cpu} is not available to this process: use one of {', '.join(map(str, allowed))}")
    os.sched_setaffinity(0, {cpu})


def last_cpu() -> int:
    """The highest-numbered CPU this process may use: CPU 0 usually takes the most interrupts."""
    return max(os.sched_getaffinity(0))


def _set_policy(priority: int) -> Scheduling:
    if priority == 0:
        return Scheduling("SCHED_OTHER", 0)
    if not hasattr(os, "sched_setscheduler"):
        return _normal(f"SCHED_FIFO is not available on {os.name}")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        return _normal("SCHED_FIFO not permitted: run as root or grant rtprio in /etc/security/limits.conf")
    if not _lock_memory():
        log.warning("memory not locked (mlockall refused): grant memlock in /etc/security/limits.conf; page faults may stall cycles")
        return Scheduling("SCHED_FIFO", priority, "memory not locked")
    return Scheduling("SCHED_FIFO", priority)


def _lock_memory() -> bool:
    """mlockall(MCL_CURRENT | MCL_FUTURE); False where refused or unavailable."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return bool(libc.mlockall(MCL_CURRENT | MCL_FUTURE) == 0)
    except (OSError, AttributeError):
        return False


_IDLE_LATENCY: list[object] = []  # the open PM QoS request: the kernel keeps it while the file stays open


def _hold_idle_latency() -> bool:
    """Ask the kernel to keep every CPU out of deep idle states for as long as this process runs (False where refused)."""
    if _IDLE_LATENCY:
        return True
    try:
        request = open(PM_QOS_CPU_LATENCY, "wb", buffering=0)  # noqa: SIM115 - held open on purpose, for the process's lifetime
        request.write((0).to_bytes(4, sys.byteorder, signed=True))
    except OSError:
        log.warning("CPU idle latency not held (%s not writable): cycles after idle time may run slower", PM_QOS_CPU_LATENCY)
        return False
    _IDLE_LATENCY.append(request)
    return True


def _normal(why: str) -> Scheduling:
    log.warning("%s; running at normal priority, expect late cycles under load", why)
    return Scheduling("SCHED_OTHER", 0, why)
