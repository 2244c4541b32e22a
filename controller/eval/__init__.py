"""Robustness evaluation: suites of episodes (scenarios x policies x perturbations x seeds), run locally or on Ray."""
