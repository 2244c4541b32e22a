"""Trackers: robot state plus a reference window in, joint command out (`tracker.Tracker`), chosen by name (`registry`)."""
