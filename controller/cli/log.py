"""`g1ctl log`: read a flight recording (`--record FILE.mcap` on sim, run and plan).

g1ctl log info FILE                                   topics, message counts, time span, faults and mode changes
g1ctl log plot FILE [--joints NAME,...] [--out PNG]   commanded against measured velocity; chosen joints' target against measured
g1ctl log replay FILE --video OUT.mp4 [--fps 20]      a video rendered in MuJoCo from the recorded states, the plan as a ghost

A file that is no MCAP is refused in one line (exit status 2); a file cut off (a run that was
killed before it could finish it) is read up to the cut, with one line on stderr saying so.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hw.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    log = sub.add_parser("log", help="read a flight recording (--record FILE.mcap): info, plot, replay")
    log_sub = log.add_subparsers(dest="log_command", required=True)
    info = log_sub.add_parser("info", help="topics, message counts, time span, faults and mode changes")
    info.add_argument("file", type=Path)
    plot = log_sub.add_parser("plot", help="commanded against measured velocity, and chosen joints' target against measured")
    plot.add_argument("file", type=Path)
    plot.add_argument("--joints", default=None, help="comma-separated joint names (left_knee or left_knee_joint): one panel each")
    plot.add_argument("--out", type=Path, default=None, help="the PNG (default: beside the recording, .png)")
    replay = log_sub.add_parser("replay", help="a video rendered in MuJoCo from the recorded states, the plan as a ghost")
    replay.add_argument("file", type=Path)
    replay.add_argument("--video", type=Path, required=True, help="the .mp4 or .gif to write")
    replay.add_argument("--fps", type=int, default=20)


def run(args: argparse.Namespace) -> int:
    if args.log_command == "info":
        from controller.recording.info import info  # noqa: PLC0415

        lines, warning = info(args.file)
        _warn(warning)
        print("\n".join(lines))
        return 0
    if args.log_command == "plot":
        from controller.recording.plot import plot_recording  # noqa: PLC0415

        joints = [name.strip() for name in args.joints.split(",") if name.strip()] if args.joints else []
        out = args.out or args.file.with_suffix(".png")
        _warn(plot_recording(args.file, out, joints).warning())
        print(f"plot: {out}")
        return 0
    if args.video.suffix.lower() not in (".mp4", ".gif"):
        raise ConfigError(f"--video {args.video}: the video is an .mp4 or a .gif")
    from sim import use_headless_gl  # noqa: PLC0415

    use_headless_gl()  # before MuJoCo is imported
    from controller.recording.replay import replay_video  # noqa: PLC0415

    recording, frames = replay_video(args.file, args.video, args.fps, args.assets_dir)
    _warn(recording.warning())
    print(f"video: {args.video} ({frames} frames)")
    return 0


def _warn(warning: str | None) -> None:
    if warning is not None:
        print(f"g1ctl: warning: {warning}", file=sys.stderr)
