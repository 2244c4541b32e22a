"""The command vocabulary: what a velocity command, its limits, a gesture and a waypoint mean.

The lowest role folder of `controller/`: inputs, references, trackers and the motion dataset
all speak it, and it imports nothing else of `controller/`.
"""
