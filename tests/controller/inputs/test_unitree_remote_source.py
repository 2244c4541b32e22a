"""The G1's remote as an input: remote_bytes inverts map_remote; the source reads LowState_s on loopback DDS."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pytest

from controller.cli.robot import _remote
from controller.commands.velocity import CommandLimits, VelocityCommand
from controller.inputs.base import Buttons, CommandSample, CommandSource
from controller.inputs.registry import REMOTE_NEEDS_DDS, check_input, open_input
from controller.inputs.unitree_remote import RemoteConfig, map_remote, remote_bytes
from hw.dds.config import DdsHardwareConfig
from hw.dds.session import DdsConfig
from hw.errors import ConfigError
from hw.jointmap import load_robot_config
from hw.protocols import unitree_hg as hg
from tests.conftest import HANG_S, wait_for

LIMITS = CommandLimits(vx=(-0.6, 1.0), vy=(-0.5, 0.4), yaw_rate=(-1.2, 0.8))
Publish = Callable[..., None]


def round_trip(sample: CommandSample, limits: CommandLimits = LIMITS) -> CommandSample:
    cfg = RemoteConfig()
    return map_remote(hg.decode_wireless_remote(remote_bytes(sample, limits, cfg)), cfg, limits)


def assert_same(got: CommandSample, want: CommandSample) -> None:
    assert (got.buttons, got.alive, got.gesture) == (want.buttons, want.alive, want.gesture)
    g, w = got.velocity, want.velocity
    assert np.allclose([g.vx, g.vy, g.yaw_rate], [w.vx, w.vy, w.yaw_rate], atol=1e-6)


@pytest.mark.parametrize(
    "velocity",
    [VelocityCommand(), VelocityCommand(0.5, 0.0, 0.0), VelocityCommand(-0.6, 0.4, -1.2), VelocityCommand(1.0, -0.5, 0.8),
     VelocityCommand(-0.01, 0.003, 0.2), VelocityCommand(0.3, -0.2, -0.5)],
)  # fmt: skip
def test_remote_bytes_read_back_as_the_same_command(velocity: VelocityCommand) -> None:
    assert_same(round_trip(CommandSample(velocity=velocity)), CommandSample(velocity=velocity))


def test_buttons_and_gestures_read_back_and_a_gesture_without_a_button_is_refused() -> None:
    for buttons in (Buttons(start=True), Buttons(stop=True), Buttons(estop=True), Buttons(True, True, True)):
        for gesture in ("", "wave", "raise_both", "point"):
            sample = CommandSample(velocity=VelocityCommand(0.2, 0.1, 0.0), buttons=buttons, gesture=gesture)
            assert_same(round_trip(sample), sample)
    with pytest.raises(ConfigError, match=r"gesture 'reach' has no button on the G1's remote \(it has buttons for wave, raise_both, point"):
        remote_bytes(CommandSample(gesture="reach"), LIMITS)


def test_a_command_beyond_the_limits_saturates_the_stick_and_a_dead_input_centres_it() -> None:
    saturated = CommandSample(velocity=VelocityCommand(1.0, -0.5, 0.8))
    assert_same(round_trip(CommandSample(velocity=VelocityCommand(3.0, -3.0, 3.0))), saturated)
    dead = CommandSample(velocity=VelocityCommand(0.5), buttons=Buttons(estop=True), alive=False)
    remote = hg.decode_wireless_remote(remote_bytes(dead, LIMITS))
    assert (remote.lx, remote.ly, remote.rx) == (0.0, 0.0, 0.0) and remote.buttons == {"B"}


def test_the_remote_needs_a_dds_hardware_config() -> None:
    from controller.runtime.run_config import RunConfig
    from controller.runtime.run_plan import resolve_run

    for hardware in (None, "sim-can"):  # a run on the simulator, or on buses: no robot over DDS to read the remote from
        with pytest.raises(ConfigError) as info:
            resolve_run(RunConfig(input="unitree-remote", hardware=hardware))
        assert str(info.value) == REMOTE_NEEDS_DDS
    with pytest.raises(ConfigError) as info:
        check_input("unitree-remote", None)
    assert str(info.value) == REMOTE_NEEDS_DDS
    with pytest.raises(ConfigError, match="add --hardware g1-dds"):
        open_input("unitree-remote", LIMITS, None, 0.0, 0)
    sim_dds = load_robot_config("sim-dds")
    assert isinstance(sim_dds, DdsHardwareConfig)
    check_input("unitree-remote", sim_dds.dds)
    assert resolve_run(RunConfig(input="unitree-remote", hardware="sim-dds")).input == "unitree-remote"
    check_input("gamepad")


def test_the_robot_cli_feeds_a_scenario_as_remote_bytes(tmp_path: Path) -> None:
    feed = _remote("walk_turn_stop", ExitStack())
    assert feed is not None
    read = [map_remote(hg.decode_wireless_remote(feed(t)), RemoteConfig(), CommandLimits()).velocity for t in (0.5, 2.0, 6.0, 10.0, 13.0)]
    want = [VelocityCommand(), VelocityCommand(vx=0.5), VelocityCommand(yaw_rate=0.6), VelocityCommand(vy=0.3), VelocityCommand(vx=-0.4)]
    assert np.allclose([[v.vx, v.vy, v.yaw_rate] for v in read], [[v.vx, v.vy, v.yaw_rate] for v in want], atol=1e-6)
    scenario = tmp_path / "reach.yaml"
    scenario.write_text("duration: 4.0\nsteps:\n  - {t: 0.0}\n  - {t: 2.0, gesture: reach}\n")
    with pytest.raises(ConfigError, match=r"--remote .*reach.yaml: at 2 s, gesture 'reach' has no button"):
        _remote(str(scenario), ExitStack())


# ---- the source on loopback DDS ------------------------------------------------------------------


@pytest.fixture
def domain(claim_dds_domain: Callable[[], int]) -> int:
    """A DDS domain of the test's own."""
    return claim_dds_domain()


@pytest.fixture
def publish(domain: int) -> Iterator[Publish]:
    """A function that publishes one LowState_ carrying a remote (its CRC broken with `bad_crc`) on the test's `domain`."""
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    from hw.dds import cdr, messages
    from hw.dds.session import DdsSession

    session = DdsSession(DdsConfig(domain=domain, interface="lo"))
    writer = session.writer("rt/lowstate", messages.LowState_)

    def send(sample: CommandSample, bad_crc: bool = False) -> None:
        record = np.zeros((), dtype=hg.LOW_STATE)
        record["wireless_remote"] = np.frombuffer(remote_bytes(sample, LIMITS), dtype=np.uint8)
        record = hg.with_crc(record)
        if bad_crc:
            record["crc"] ^= 1
        DdsSession.write_cdr(writer, cdr.low_state_to_cdr(record))

    yield send
    session.close()


def poll_until(
    source: CommandSource, cond: Callable[[CommandSample], bool], send: Callable[[], None] | None = None, timeout: float = HANG_S
) -> CommandSample:
    """Send (when given) and poll every 10 ms until `cond(polled)` holds or `timeout` s pass; the last sample."""
    deadline = time.monotonic() + timeout
    while True:
        if send is not None:
            send()
        got = source.poll(0.0)
        if cond(got) or time.monotonic() > deadline:
            return got
        time.sleep(0.01)


def test_open_input_reads_the_remote_on_the_hardware_configs_domain(tmp_path: Path, domain: int) -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    from controller.inputs.unitree_remote import UnitreeRemoteSource
    from hw.shipped import config_dir

    hardware = tmp_path / "remote-dds.yaml"
    hardware.write_text((config_dir("hardware") / "sim-dds.yaml").read_text().replace("domain: 1,", f"domain: {domain},"))
    config = load_robot_config(str(hardware))
    assert isinstance(config, DdsHardwareConfig)
    with open_input("unitree-remote", LIMITS, None, 0.0, 0, config.dds) as source:
        assert isinstance(source, UnitreeRemoteSource) and source._session.cfg.domain == domain
        assert not source.poll(0.0).alive  # no robot on this domain


def test_the_source_reads_the_remote_and_goes_stale_when_states_stop(publish: Publish, domain: int) -> None:
    from controller.inputs.unitree_remote import UnitreeRemoteSource

    walk = CommandSample(velocity=VelocityCommand(0.5, -0.2, 0.4), buttons=Buttons(start=True), gesture="wave")
    with UnitreeRemoteSource(DdsConfig(domain=domain, interface="lo"), LIMITS, RemoteConfig(stale_timeout=0.2)) as source:
        assert not source.poll(0.0).alive  # nothing heard yet
        got = poll_until(source, lambda s: s.alive, lambda: publish(walk))
        assert_same(got, walk)
        got = poll_until(source, lambda s: not s.alive)
        assert not got.alive and got.velocity == VelocityCommand() and time.monotonic() - source.state_time >= 0.2  # since the last state
        assert got.buttons == walk.buttons  # the last buttons still read (an e-stop held stays held)


def test_states_with_a_bad_crc_are_counted_and_ignored(publish: Publish, domain: int) -> None:
    from controller.inputs.unitree_remote import UnitreeRemoteSource

    stand = CommandSample()
    with UnitreeRemoteSource(DdsConfig(domain=domain, interface="lo"), LIMITS, RemoteConfig(stale_timeout=0.3)) as source:
        assert poll_until(source, lambda s: s.alive, lambda: publish(stand)).alive
        bad = CommandSample(velocity=VelocityCommand(1.0), buttons=Buttons(estop=True))
        seen = []

        def counted_until_stale() -> bool:  # bad states alone, until the remote is stale
            publish(bad, bad_crc=True)
            seen.append(source.poll(0.0))
            return source.crc_errors > 10 and not seen[-1].alive

        assert wait_for(counted_until_stale)
        assert source.crc_errors > 10
        assert all(s.velocity == VelocityCommand() and not s.buttons.estop for s in seen)
        assert not seen[-1].alive  # bad states do not keep the remote alive


@pytest.mark.slow  # a MuJoCo process on the wall clock
def test_the_simulated_robot_sends_a_scenario_on_its_remote(domain: int) -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    from controller.inputs.unitree_remote import UnitreeRemoteSource
    from hw.dds import messages as m
    from hw.dds.session import DdsSession

    child = subprocess.Popen(
        [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "6", "--motion-mode", "",
         "--remote", "walk_turn_stop"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    dds = DdsConfig(domain=domain, interface="lo")
    session = DdsSession(dds)
    try:
        with UnitreeRemoteSource(dds, CommandLimits()) as source:
            states = session.reader("rt/lowstate", m.LowState_)
            assert poll_until(source, lambda s: s.alive).alive
            assert wait_for(lambda: any(isinstance(s, m.LowState_) and s.tick >= 1500 for s in states.take(N=10)))  # up 1.5 s
            assert source.poll(0.0).velocity == VelocityCommand()  # its time line waits for the first command
            command = hg.new_low_cmd(mode_machine=5)
            command["motor_cmd"]["mode"][:29], command["motor_cmd"]["kd"][:29] = 1, 1.0
            writer, message = session.writer("rt/lowcmd", m.LowCmd_), m.low_cmd_from_record(hg.with_crc(command))
            got = poll_until(source, lambda s: s.velocity.vx > 0.0, lambda: writer.write(message))
            assert np.isclose(got.velocity.vx, 0.5, atol=1e-6) and got.alive  # walk_turn_stop: forward at 0.5 m/s from 1 s
    finally:
        session.close()
    out, err = child.communicate(timeout=20)
    assert child.returncode == 0, err
    assert json.loads(out.strip().splitlines()[-1])["commands"] >= 1
