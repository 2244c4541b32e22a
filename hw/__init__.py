"""Hardware-facing interfaces of the G1 stack: robot state and command types, errors.

Imports nothing from `controller` or `sim`, so a robot can be driven without MuJoCo.
"""
