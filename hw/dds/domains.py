"""A DDS domain of its own for each simulated robot on this machine, so parallel runs never hear each other.

A simulated G1 and its host share a domain on loopback. Two such runs on one machine (an
evaluation sweep with several workers, two terminals) on the same domain would take each
other's commands. Each run claims its config's domain, or the next free one, with a lock file
that the operating system releases when the process ends, however it ends.
"""

from __future__ import annotations

import fcntl
import tempfile
from pathlib import Path
from typing import IO

from hw.errors import ConfigError

SPARE_DOMAINS = range(100, 233)  # tried in order when the preferred one is taken (232: the highest DDS domain id)


class DomainClaim:
    """A domain held until `release()` (or the process's end)."""

    def __init__(self, domain: int, lock: IO[str]) -> None:
        self.domain = domain
        self._lock: IO[str] | None = lock

    def release(self) -> None:
        if self._lock is not None:
            self._lock.close()  # closing the file drops its lock
            self._lock = None


def claim_domain(preferred: int, lock_dir: Path | None = None) -> DomainClaim:
    """`preferred` when no other run on this machine holds it, else the first free spare domain."""
    folder = lock_dir or Path(tempfile.gettempdir())
    for domain in (preferred, *(d for d in SPARE_DOMAINS if d != preferred)):
        lock = (folder / f"g1ctl-dds-domain-{domain}.lock").open("w")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        return DomainClaim(domain, lock)
    raise ConfigError(f"every DDS domain from {SPARE_DOMAINS.start} to {SPARE_DOMAINS.stop - 1} is held by another simulated run")
