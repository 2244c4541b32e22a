"""The benchmarks run and report what they promise (no timing is asserted: that is their job, not a test's)."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path

import pytest

from controller.bench.bus_robot import run_bus_robot_bench
from controller.bench.hw import run_hw_bench
from controller.bench.loop import run_loop_bench
from controller.bench.recorder import run_recorder_bench
from controller.bench.typed import ACCEPTED_POOL, REFUSED_POOL, TypedBenchConfig, run_typed_bench, schedule
from hw.errors import ConfigError


def test_loop_bench_reports_both_loops() -> None:
    report = run_loop_bench("fastsac", rounds=1, duration=2.0, assets_dir=None)
    assert report["stack_rtf"] > 0 and report["minimal_rtf"] > 0
    assert report["ratio"] == pytest.approx(report["stack_rtf"] / report["minimal_rtf"], abs=2e-3)  # both sides rounded to 3 places


@pytest.mark.slow
def test_recorder_bench_reports_both_sides_and_keeps_its_recordings_where_asked(tmp_path: Path) -> None:
    report = run_recorder_bench(duration=2.0, rounds=1, keep=tmp_path)
    assert report["wall_per_tick_ms"]["off"] > 0 and report["wall_per_tick_ms"]["on"] > 0 and report["control_period_ms"] == 20.0
    loop, others = report["loop_cpu_per_tick_ms"], report["other_cpu_per_tick_ms"]
    assert report["overhead_ms"] == pytest.approx(loop["on"] - loop["off"] + others["on"] - others["off"], abs=1e-3)  # rounded figures
    assert report["overhead_share"] == pytest.approx(report["overhead_ms"] / 20.0, abs=1e-4)
    assert report["messages"] > 100 * 8 and set(report["record_ms"]) == {"p50", "p99"}
    assert report["targets_met"] == (report["overhead_share"] <= 0.05 and report["drops"] == 0)
    assert (tmp_path / "round0.mcap").stat().st_size > 10_000


@pytest.mark.slow
def test_hw_bench_reports_cycle_and_raw_round_trip() -> None:
    report = run_hw_bench(seconds=0.6, rt_priority=0, cpu=-1)  # pins nothing: the pytest process keeps its CPUs
    assert report["cycles"] > 100
    assert set(report["cycle_ms"]) == set(report["raw_round_trip_ms"]) == {"p50", "p99"}
    assert report["counters"]["frames_received"] >= 29 * report["cycles"]
    assert report["counters"]["crc_errors"] == 0


@pytest.mark.slow
def test_buses_bench_reports_each_rate_and_the_highest_held() -> None:
    report = run_bus_robot_bench([250.0], seconds=1.0)
    (rate,) = report["rates"]
    assert rate["rate_hz"] == 250.0 and rate["cycle_period_ms"]["target"] == 4.0 and set(rate["cycle_ms"]) == {"p50", "p99"}
    assert 200 < rate["cycles"] + rate["missed_cycles"] <= 260 and rate["reply_timeout_ms"] == 3.0
    assert report["highest_rate_held"] == (250.0 if rate["held"] else None) and len(report["load_average"]) == 3
    assert rate["robot_step_ms"]["p50"] > 0  # the robot process stepped its physics: the host held a pose, stiffly


@pytest.mark.slow
def test_dds_bench_reports_cycle_and_both_raw_round_trips(sim_dds_config: Callable[[], Path]) -> None:
    pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")
    from controller.bench.dds import run_dds_bench

    report = run_dds_bench(seconds=1.0, rt_priority=0, cpu=-1, hardware=str(sim_dds_config()))
    assert report["cycles"] > 250  # half of 500 Hz for 1 s: a loaded machine takes fewer
    assert set(report["cycle_ms"]) == set(report["raw_round_trip_ms"]) == set(report["raw_wire_round_trip_ms"]) == {"p50", "p99"}
    assert report["ratio"] == pytest.approx(report["cycle_ms"]["p50"] / report["raw_round_trip_ms"]["p50"], abs=2e-3)
    counters, robot = report["counters"], report["robot_process"]
    assert counters["states_received"] >= report["cycles"] and counters["crc_errors"] == 0
    assert robot["exit_code"] == 0 and robot["commands"] >= report["cycles"] and robot["crc_errors"] == 0


def test_typed_bench_script_is_seeded_within_its_gaps_with_its_refusals() -> None:
    cfg = TypedBenchConfig(instructions=12, refused=3, seed=4, min_gap_s=0.5, max_gap_s=2.0)
    sends = schedule(cfg)
    assert sends == schedule(cfg) and sends != schedule(TypedBenchConfig(instructions=12, refused=3, seed=5))
    assert sum(s.refusal_expected for s in sends) == 3
    assert all((s.text in REFUSED_POOL) == s.refusal_expected and (s.text in ACCEPTED_POOL) != s.refusal_expected for s in sends)
    gaps = [b.at_s - a.at_s for a, b in itertools.pairwise(sends)]
    assert all(0.5 - 1e-3 <= gap <= 2.0 + 1e-3 for gap in gaps)
    with pytest.raises(ConfigError, match="--refused"):
        TypedBenchConfig(instructions=2, refused=3)


@pytest.mark.slow
def test_typed_bench_reports_the_latency_of_each_accepted_instruction() -> None:
    report = run_typed_bench(TypedBenchConfig(instructions=3, refused=1, seed=5, min_gap_s=0.5, max_gap_s=1.0))
    assert report["instructions_sent"] == 3 and report["sender_error"] is None
    assert (report["accepted"], report["refused"], report["refused_unexpected"]) == (2, 1, [])
    latency = report["first_plan_latency_s"]
    assert latency["n"] == 2 and 0 < latency["p50"] <= latency["p95"] <= latency["max"]
    assert report["targets_met"] == (latency["p95"] <= 0.3 and report["falls"] == 0)
    assert len(report["machine"]["load_average_before"]) == 3 and report["real_time_factor"] is not None
