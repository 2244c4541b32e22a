"""Simulated hardware: motor firmware and IMU emulators behind real buses and ports.

Each emulator listens where the real device would (a python-can `virtual` bus, the far
end of a pseudo-terminal), answers byte for byte like the firmware, and takes its joint
states from a `Plant` (MuJoCo physics in `sim.hardware_twin`). Faults are injected
through a mutable `FaultPlan`.
"""
