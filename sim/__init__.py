"""MuJoCo world of the Unitree G1: scene, simulated robot, rendering."""
