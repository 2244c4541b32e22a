"""A Cyclone DDS participant on the G1's domain and network interface, with best-effort writers and readers.

The robot publishes `rt/lowstate` and takes `rt/lowcmd` on domain 0 over its own network
interface; the simulated robot uses domain 1 on `lo`. Discovery is unicast to the interface's
peers (`peers`, default none: multicast on the interface), so a loopback run needs no multicast.
Best effort, keep last 1: a control message that is late is worth nothing, and a resend would
only delay the next one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from xml.sax.saxutils import quoteattr

from hw.dds import require_cyclonedds
from hw.errors import ConfigError


@dataclass(frozen=True)
class DdsConfig:
    domain: int = 1
    interface: str = "lo"
    peers: tuple[str, ...] = ("127.0.0.1",)  # unicast discovery; empty: multicast on the interface
    lowcmd_topic: str = "rt/lowcmd"
    lowstate_topic: str = "rt/lowstate"

    def __post_init__(self) -> None:
        if not 0 <= self.domain <= 232:
            raise ConfigError(f"DDS domain must be 0..232, got {self.domain}")
        if not self.interface:
            raise ConfigError("DDS interface must name a network interface (e.g. lo, eth0, enp3s0)")


def domain_xml(cfg: DdsConfig) -> str:
    """The Cyclone DDS configuration of the domain: which interface, which discovery peers."""
    peers = "".join(f"<Peer address={quoteattr(p)}/>" for p in cfg.peers)
    multicast = "false" if cfg.peers else "true"
    return (
        f'<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name={quoteattr(cfg.interface)}/></Interfaces>'
        f"<AllowMulticast>{multicast}</AllowMulticast></General>"
        f"<Discovery><ParticipantIndex>auto</ParticipantIndex><Peers>{peers}</Peers></Discovery></Domain></CycloneDDS>"
    )


_DOMAINS: dict[int, tuple[str, Any]] = {}  # domain id -> (its XML, the Domain): Cyclone takes one configuration per domain and process


def _joined_domain(cfg: DdsConfig, domain_type: Any) -> Any:
    """The process's `Domain` for `cfg.domain`, created on first use; a second session on it shares it (same interface and peers)."""
    xml = domain_xml(cfg)
    if cfg.domain in _DOMAINS:
        joined_xml, domain = _DOMAINS[cfg.domain]
        if joined_xml != xml:
            raise ConfigError(f"DDS domain {cfg.domain} is already joined in this process with another interface or peers")
        return domain
    domain = domain_type(cfg.domain, xml)
    _DOMAINS[cfg.domain] = (xml, domain)
    return domain


class DdsSession:
    """One participant; `writer(topic, type)` and `reader(topic, type)` with the control QoS. `close()` releases it."""

    def __init__(self, cfg: DdsConfig) -> None:
        require_cyclonedds()
        from cyclonedds.core import Policy, Qos  # noqa: PLC0415 - the optional extra
        from cyclonedds.domain import Domain, DomainParticipant  # noqa: PLC0415

        self.cfg = cfg
        self._domain: Any = None
        self.participant: Any = None
        try:
            self._domain = _joined_domain(cfg, Domain)
            self.participant = DomainParticipant(cfg.domain)
        except Exception as exc:  # cyclonedds raises its own DDSException: name the config that failed
            raise ConfigError(f"cannot join DDS domain {cfg.domain} on interface '{cfg.interface}': {exc}") from exc
        self._qos = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1))
        self._topics: dict[str, Any] = {}
        self._waitsets: list[Any] = []

    def _topic(self, name: str, datatype: type) -> Any:
        from cyclonedds.topic import Topic  # noqa: PLC0415

        if name not in self._topics:
            self._topics[name] = Topic(self.participant, name, datatype)
        return self._topics[name]

    def writer(self, topic: str, datatype: type, qos: Any = None) -> Any:
        """A writer with the control QoS, or `qos` (a `cyclonedds.core.Qos`) where a topic needs another."""
        from cyclonedds.pub import DataWriter  # noqa: PLC0415

        return DataWriter(self.participant, self._topic(topic, datatype), qos=self._qos if qos is None else qos)

    def reader(self, topic: str, datatype: type, qos: Any = None) -> Any:
        from cyclonedds.sub import DataReader  # noqa: PLC0415

        return DataReader(self.participant, self._topic(topic, datatype), qos=self._qos if qos is None else qos)

    def wait_set(self, *readers: Any) -> Callable[[float], None]:
        """A function that blocks until one of `readers` has a sample, or the timeout (s) passes."""
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet  # noqa: PLC0415

        waitset = WaitSet(self.participant)
        for reader in readers:
            waitset.attach(ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any))
        self._waitsets.append(waitset)

        def wait(timeout_s: float) -> None:
            waitset.wait(max(int(timeout_s * 1e9), 0))

        return wait

    @staticmethod
    def write_cdr(writer: Any, data: bytes) -> None:
        """Publish already serialized CDR (`hw.dds.cdr`): Cyclone's Python serializer takes 0.3-0.8 ms on these messages."""
        DdsSession.cdr_writer(writer)(data)

    @staticmethod
    def take_cdr(reader: Any, count: int = 16) -> list[bytes]:
        """The serialized samples waiting at `reader` (those with data; a writer leaving sends one without)."""
        return DdsSession.cdr_taker(reader, count)()

    @staticmethod
    def cdr_writer(writer: Any) -> Callable[[bytes], None]:
        """`write_cdr` bound to one writer, the imports done once: for a 500 Hz loop."""
        from cyclonedds._clayer import ddspy_write  # noqa: PLC0415 - the binding's raw write, as DataWriter.write calls it

        ref = writer._ref

        def write(data: bytes) -> None:
            ret = ddspy_write(ref, data)
            if ret < 0:
                raise ConfigError(f"DDS write failed with code {ret} on {writer}")

        return write

    @staticmethod
    def cdr_taker(reader: Any, count: int = 16) -> Callable[[], list[bytes]]:
        """`take_cdr` bound to one reader, the imports done once: for a 500 Hz loop."""
        from cyclonedds._clayer import ddspy_take  # noqa: PLC0415
        from cyclonedds.core import InstanceState, SampleState, ViewState  # noqa: PLC0415

        ref, mask = reader._ref, SampleState.Any | ViewState.Any | InstanceState.Any

        def take() -> list[bytes]:
            taken = ddspy_take(ref, mask, count)
            if isinstance(taken, int):
                raise ConfigError(f"DDS take failed with code {taken} on {reader}")
            return [data for data, info in taken if info.valid_data]

        return take

    def close(self) -> None:
        """Drop the participant (its readers and writers with it)."""
        self._topics.clear()
        self._waitsets.clear()
        self.participant = None
        self._domain = None
