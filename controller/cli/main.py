"""g1ctl: command line of the G1 controller stack.

Usage (each command group's module shows its own):
    g1ctl sim ...                 run a scenario on the simulated G1 (controller/cli/sim.py)
    g1ctl run ...                 drive it through the planner: viewer or headless, keyboard, gamepad (controller/cli/run.py)
    g1ctl hw ...                  bench bring-up on real or simulated hardware (controller/cli/hw.py)
    g1ctl robot --dds             a simulated G1 in its own process on the robot's DDS topics (controller/cli/robot.py)
    g1ctl plan "PROMPT" [--sim]   a typed instruction planned into clauses, run on the simulated G1 (controller/cli/plan.py)
    g1ctl tell "INSTRUCTION" --to PATH   an instruction to a run taking them (g1ctl run --instructions PATH; controller/cli/tell.py)
    g1ctl bench loop|hw|dds|recorder|inbetween|text|typed   benchmarks with JSON reports (controller/cli/bench.py)
    g1ctl eval --suite NAME       a robustness sweep, locally or on Ray (controller/cli/eval.py)
    g1ctl log info|plot|replay FILE   read a flight recording made with --record FILE.mcap (controller/cli/log.py)
    g1ctl dataset record|import|info   the planner's motion dataset (controller/cli/dataset.py)
    g1ctl train planner, g1ctl viz plan   the planner (controller/cli/planner.py)
    g1ctl assets fetch|path, g1ctl scenarios   assets, and what ships by name (controller/cli/catalog.py)

Every command that needs the G1 model or policies fetches them first (see `g1ctl assets`).
A mistake in the input ends with one line on stderr and exit status 2; a prompt the text
planner refuses (it cannot do what was asked, or the prompt is empty, too long or not text),
a fault during a run, or a run aborted by an error, with exit status 1 (a run's report written
first).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from controller.cli import bench, catalog, dataset, log, plan, planner, robot, run, sim, tell
from controller.cli import eval as eval_commands
from controller.cli import hw as hw_commands
from controller.text.program import PromptRefused
from hw.errors import G1Error, HardwareFault, RunAborted

# Command name -> the module that parses it and runs it. Each module imports its heavy
# dependencies (MuJoCo, onnxruntime, torch) only when its command runs.
COMMANDS: dict[str, ModuleType] = {
    "sim": sim, "run": run, "hw": hw_commands, "plan": plan, "bench": bench, "dataset": dataset,
    "train": planner, "viz": planner, "assets": catalog, "scenarios": catalog, "robot": robot, "eval": eval_commands, "log": log,
    "tell": tell,
}  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="g1ctl", description="Unitree G1 controller stack")
    parser.add_argument("--assets-dir", default=None, help="verified local copies of the assets (also G1CTL_ASSETS_DIR)")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in dict.fromkeys(COMMANDS.values()):  # each module once, in order
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="g1ctl: %(message)s")
    try:
        return int(COMMANDS[args.command].run(args))
    except PromptRefused as exc:  # what was asked cannot be planned: nothing moved
        print(f"g1ctl: refused: {exc}", file=sys.stderr)
        return 1
    except (HardwareFault, RunAborted) as exc:  # the run started and ended in a fault: not a usage mistake
        print(f"g1ctl: fault: {exc}", file=sys.stderr)
        return 1
    except G1Error as exc:
        print(f"g1ctl: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("g1ctl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
