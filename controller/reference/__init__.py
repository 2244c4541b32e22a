"""The reference side: what the tracker follows (the reference window; the plan buffer and the replanning scheduler join here)."""
