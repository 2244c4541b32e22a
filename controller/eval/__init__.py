"""Whole simulated runs as seeded tasks, run locally or on Ray (`executor`).

Robustness evaluation: suites of episodes (scenarios x policies x perturbations x seeds);
and the motion dataset recorder (`dataset_recorder`), which drives runs the same way.
"""
