"""The flight recorder: every control tick of a run into an MCAP file, and the tools that read it back.

`recorder` (the session's side: one snapshot per tick, never blocking) and `sink` (the writer thread)
load no simulator, so a real robot records; `reader`, `info`, `plot` and `replay` are the offline
tools of `g1ctl log` (replay renders in MuJoCo). docs/recording.md describes the topics.
"""
