"""Clips chosen by style: name patterns for holding a style out of training and benchmarking on it alone.

A style is named by a pattern on clip names: the folder an import came from (`bonus` matches
`bonus-B_Fence1`, the clips imported from `g1-moves/bonus/`), or a glob (`dance-B_*`). Training
leaves every clip that matches out of all its splits (`g1ctl train planner --hold-out bonus`);
the benchmark then scores on those clips only, whatever their split
(`g1ctl bench inbetween --only bonus --split all`). Why: a split by clip still lets the model see
the style in its other clips; a style held out entirely is what a user's own motion looks like.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from fnmatch import fnmatchcase

from hw.errors import ConfigError


def parse_patterns(text: str, option: str) -> tuple[str, ...]:
    """Comma-separated patterns from an option's value, or ConfigError naming the option."""
    patterns = tuple(dict.fromkeys(p.strip() for p in text.split(",") if p.strip()))
    if not patterns:
        raise ConfigError(f"{option} needs clip name patterns like 'bonus' or 'dance-B_*', got '{text}'")
    return patterns


def matches(name: str, patterns: Iterable[str]) -> bool:
    """Whether a clip name is one of the patterns' style: the pattern as a glob, or as the name's folder prefix."""
    return any(fnmatchcase(name, p) or name.startswith(p + "-") for p in patterns)


def unmatched(names: Sequence[str], patterns: Iterable[str]) -> list[str]:
    """The patterns that match none of the names (a typo, or a dataset without that style)."""
    return [p for p in patterns if not any(matches(n, (p,)) for n in names)]


def folder_prefixes(names: Iterable[str]) -> list[str]:
    """The distinct folder prefixes of clip names, for an error that lists what could be chosen."""
    return sorted({n.split("-", 1)[0] for n in names})
