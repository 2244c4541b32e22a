"""What the README and docs/ show works: a command shown is a command that runs.

- The README stays a front door: at most `README_MAX_LINES` lines.
- Every relative link in README.md and docs/*.md resolves to a file inside the repository, and a
  `#anchor` to a heading of that file; no link, and no bare URL outside code, leaves the repository.
- Every `g1ctl ...` line of a shell block (README and docs) is accepted by the CLI's own argparse
  parser (`controller.cli.main.build_parser`, parsed without running), and every shipped name it
  uses (scenario, policy, tracker, hardware config, fault plan, perturbation set, suite, joint,
  motor model) exists. In the README a file path must exist in the repository too; the docs may
  show your own files (`my-g1.yaml`).
- The README's cheap commands really run, in a subprocess in a temporary directory (their outputs,
  such as `runs/...`, land there): `g1ctl scenarios`, `g1ctl hw frame encode|decode`, `g1ctl plan
  PROMPT` without `--sim` or `--hardware` (the decomposition), and each `g1ctl sim` that needs neither a display,
  the wall clock, an interactive input, hardware nor a video, bounded to 1 s of simulated time
  (`--duration 1` appended: the last one wins). The others are only parsed, because running them
  here is slow or needs what a test machine lacks: `g1ctl run` and `sim --input keyboard` are
  interactive and paced to the wall clock; `sim --hardware` runs the buses about as fast as real
  time and `sim-dds` starts a DDS robot process (DDS tests must not run beside each other);
  `--video` renders every frame; `hw` operations open hardware; `robot` serves DDS until stopped;
  `plan --sim`, `plan --hardware` and `eval` take tens of seconds to minutes.
- The Python examples of the README and docs/ run as written (a bench script's on a simulated robot).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import shlex
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import G1CTL, ROOT

README = ROOT / "README.md"
README_MAX_LINES = 250
PAGES = (README, *sorted((ROOT / "docs").glob("*.md")))

FENCE = re.compile(r"^```(\w*)\n(.*?)^```", flags=re.S | re.M)
INLINE_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFERENCE_LINK = re.compile(r"^\s*\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)", flags=re.M)
SCHEME = re.compile(r"^(?:[a-zA-Z][a-zA-Z0-9+.-]*:|//)")
SHELL_LANGUAGES = ("sh", "bash", "shell", "console")
SIM_DURATION = ("--duration", "1")


def rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def without_code(markdown: str) -> str:
    """The text outside fenced blocks and inline code spans: where links and headings are."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", markdown))


def heading_anchors(markdown: str) -> set[str]:
    """GitHub's anchors of the headings: lower case, punctuation dropped, spaces to hyphens, -N for repeats."""
    anchors: set[str] = set()
    seen: dict[str, int] = {}
    for line in FENCE.sub("", markdown).splitlines():
        match = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not match:
            continue
        slug = re.sub(r"[^\w\- ]", "", match.group(1).strip().lower()).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        anchors.add(slug if count == 0 else f"{slug}-{count}")
    return anchors


def link_targets(markdown: str) -> list[str]:
    text = without_code(markdown)
    return INLINE_LINK.findall(text) + REFERENCE_LINK.findall(text)


def link_problem(page: Path, target: str) -> str | None:
    """What is wrong with one link of `page`, or None when it resolves inside the repository."""
    if SCHEME.match(target):
        return "leaves the repository"
    path_part, _, anchor = target.partition("#")
    file = (page.parent / path_part).resolve() if path_part else page
    if not file.is_relative_to(ROOT):
        return "resolves outside the repository"
    if not file.is_file():
        return f"no such file {file}"
    if anchor and anchor not in heading_anchors(file.read_text()):
        return f"no heading '#{anchor}' in {rel(file)}"
    return None


@dataclass(frozen=True)
class Command:
    """One `g1ctl` line of a shell block: its arguments (after `g1ctl`) and where it was shown."""

    page: Path
    argv: tuple[str, ...]

    def __str__(self) -> str:
        return f"{rel(self.page)}: g1ctl {shlex.join(self.argv)}"


def shown_commands(page: Path) -> list[Command]:
    commands = []
    for language, block in FENCE.findall(page.read_text()):
        if language not in SHELL_LANGUAGES:
            continue
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words and Path(words[0]).name == "g1ctl":
                commands.append(Command(page, tuple(words[1:])))
    return commands


README_COMMANDS = shown_commands(README)
ALL_COMMANDS = [command for page in PAGES for command in shown_commands(page)]


def parse(command: Command) -> argparse.Namespace:
    from controller.cli.main import build_parser

    errors = io.StringIO()
    try:
        with contextlib.redirect_stderr(errors):
            return build_parser().parse_args(command.argv)
    except SystemExit:
        pytest.fail(f"{command}: the CLI refuses it: {errors.getvalue().strip()}")


def shipped_names() -> dict[str, set[str]]:
    """Namespace attribute -> the names that ship for it (each loader's own listing).

    Imported here, not at the top: the suite loader pulls in MuJoCo, which collecting tests should not pay for.
    """
    from controller.eval.suite import available_suites
    from controller.inputs.scripted import available_scenarios
    from controller.tracking.presets import available_policies
    from controller.tracking.registry import available_trackers
    from hw import g1
    from hw.emulation.faults import available_fault_plans
    from hw.jointmap import available_hardware, load_motor_models
    from hw.shipped import config_dir
    from hw.yamlconfig import preset_names

    scenarios = set(available_scenarios())
    return {
        "scenario": scenarios,
        "policy": set(available_policies()),
        "tracker": set(available_trackers()),
        "hardware": set(available_hardware()),
        "faults": set(available_fault_plans()),
        "perturb": set(preset_names(config_dir("perturbations"))),
        "suite": set(available_suites()),
        "joint": set(g1.JOINT_NAMES),
        "model": set(load_motor_models()),
        "remote": scenarios | {"keyboard", "gamepad"},
    }


def is_path(value: str) -> bool:
    return "/" in value or value.endswith((".yaml", ".yml"))


def name_problems(command: Command, args: argparse.Namespace, shipped: dict[str, set[str]]) -> list[str]:
    problems = []
    for key, names in shipped.items():
        value = getattr(args, key, None)
        if not isinstance(value, str):  # absent, or a Path option (data folders, outputs) of the same name
            continue
        if is_path(value):
            if command.page == README and not (ROOT / value).is_file():
                problems.append(f"--{key} {value}: the README shows only what ships, and there is no such file")
        elif value not in names:
            problems.append(f"--{key} {value}: no such {key} ships (shipped: {', '.join(sorted(names))})")
    return problems


def runs_here(command: Command) -> bool:
    """The README's cheap commands, run for real (see the module docstring for why the others are not)."""
    argv = command.argv
    if argv[:1] == ("scenarios",) or argv[:2] == ("hw", "frame"):
        return True
    if argv[:1] == ("plan",):
        return "--sim" not in argv and "--hardware" not in argv
    if argv[:1] == ("sim",):
        interactive = any(flag in argv for flag in ("--viewer", "--realtime", "--hardware", "--faults", "--video"))
        return not interactive and ("--input" not in argv or argv[argv.index("--input") + 1] == "scripted")
    return False


def test_the_readme_is_a_front_door() -> None:
    lines = README.read_text().count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines (at most {README_MAX_LINES}): move detail into docs/"


def test_the_readme_leads_to_every_docs_page() -> None:
    linked = {(ROOT / target.partition("#")[0]).resolve() for target in link_targets(README.read_text())}
    orphans = [rel(page) for page in PAGES[1:] if page not in linked]
    assert len(PAGES) > 1 and orphans == [], f"docs pages the README does not link: {orphans}"


@pytest.mark.parametrize("page", PAGES, ids=rel)
def test_every_link_resolves_inside_the_repository(page: Path) -> None:
    markdown = page.read_text()
    problems = [f"({target}): {problem}" for target in link_targets(markdown) if (problem := link_problem(page, target))]
    problems += [f"bare URL {url}" for url in re.findall(r"\bhttps?://\S+", without_code(markdown))]
    assert problems == [], f"{rel(page)}: " + "; ".join(problems)


def test_the_link_checker_finds_what_is_wrong(tmp_path: Path) -> None:
    page = ROOT / "docs" / "design.md"
    assert link_problem(page, "../README.md#two-commands") is None
    assert link_problem(page, "#one-tick") is None
    assert link_problem(page, "../../shared/DESIGN.md") == "resolves outside the repository"
    assert link_problem(page, "https://example.org/") == "leaves the repository"
    assert link_problem(page, "missing.md") is not None
    assert link_problem(page, "#no-such-heading") == "no heading '#no-such-heading' in docs/design.md"
    assert heading_anchors("# The robot's network\n## Lifecycle\n## Lifecycle\n") == {"the-robots-network", "lifecycle", "lifecycle-1"}
    assert link_targets("[a](x.md) `[b](y.md)` ![c](z.png)\n```\n[d](w.md)\n```\n[e]: v.md\n") == ["x.md", "z.png", "v.md"]


def test_the_readme_shows_the_commands_people_run() -> None:
    shown = {command.argv[0] for command in README_COMMANDS}
    assert shown >= {"sim", "run", "plan", "hw", "robot", "eval"}, f"the README shows g1ctl {sorted(shown)}"


@pytest.mark.parametrize("command", ALL_COMMANDS, ids=str)
def test_every_command_shown_is_accepted_by_the_cli(command: Command) -> None:
    args = parse(command)
    assert name_problems(command, args, shipped_names()) == [], command


def test_a_command_the_cli_refuses_is_caught() -> None:
    with pytest.raises(pytest.fail.Exception, match="the CLI refuses it"):
        parse(Command(README, ("sim", "--no-such-option")))
    args = parse(Command(README, ("sim", "--scenario", "walk_on_the_moon", "--hardware", "sim-can")))
    problems = name_problems(Command(README, ()), args, shipped_names())
    assert len(problems) == 1 and problems[0].startswith("--scenario walk_on_the_moon: no such scenario ships (shipped: "), problems
    args = parse(Command(README, ("sim", "--scenario", "configs/scenarios/none.yaml")))
    assert name_problems(Command(README, ()), args, shipped_names()) == [
        "--scenario configs/scenarios/none.yaml: the README shows only what ships, and there is no such file"
    ]


RUN_HERE = [command for command in README_COMMANDS if runs_here(command)]
# Measured here: a sim 4-8 s, plan 1-2.5 s, scenarios 1.1-2.3 s (it loads MuJoCo); hw frame 0.5-1.2 s.
SLOW_TO_RUN = ("sim", "plan", "scenarios")


@pytest.mark.parametrize("command", [pytest.param(c, marks=pytest.mark.slow) if c.argv[0] in SLOW_TO_RUN else c for c in RUN_HERE], ids=str)
def test_the_readmes_cheap_commands_run(command: Command, tmp_path: Path) -> None:
    argv = [*command.argv, *SIM_DURATION] if command.argv[0] == "sim" else list(command.argv)
    result = subprocess.run([*G1CTL, *argv], capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ), timeout=300)
    assert result.returncode == 0, (command, result.stdout, result.stderr)
    assert result.stdout.strip(), command
    if command.argv[:3] == ("hw", "frame", "decode"):
        assert "kind" in json.loads(result.stdout)
    if "--report" in argv:
        report = json.loads((tmp_path / argv[argv.index("--report") + 1]).read_text())
        assert report["run_seconds"] == pytest.approx(1.0) and report["falls"] == 0


def test_the_readme_runs_some_of_each_kind() -> None:
    kinds = {command.argv[0] for command in RUN_HERE}
    assert kinds >= {"scenarios", "hw", "sim"}, f"only {sorted(kinds)} of the README's commands run here"


def python_examples(bench: bool) -> list[tuple[Path, str]]:
    """The Python blocks of the README and docs/: the bench scripts (they open a simulated robot), or the others."""
    blocks = [(page, block) for page in PAGES for language, block in FENCE.findall(page.read_text()) if language == "python"]
    return [(page, block) for page, block in blocks if ("open_robot(" in block) == bench]


def test_the_python_examples_run() -> None:
    examples = python_examples(bench=False)
    assert README in {page for page, _ in examples}, "the README lost its Python example"
    for page, block in examples:
        namespace: dict[str, object] = {}
        exec(compile(block, rel(page), "exec"), namespace)
        plan = namespace["plan"]
        assert plan.qpos.shape == (44, 36) and plan.contacts.shape == (44, 2), rel(page)  # type: ignore[attr-defined]


@pytest.mark.slow
def test_the_bench_script_examples_run() -> None:
    """docs/hardware.md's bench script, on sim-can: it runs as written, and leaves the robot closed."""
    from hw.robot import Lifecycle

    examples = python_examples(bench=True)
    assert {rel(page) for page, _ in examples} == {"docs/hardware.md"}
    for page, block in examples:
        namespace: dict[str, object] = {}
        exec(compile(block, rel(page), "exec"), namespace)
        assert namespace["robot"].state is Lifecycle.CLOSED, rel(page)  # type: ignore[attr-defined]
