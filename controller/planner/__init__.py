"""The generative kinematic planner: motion data, in-betweening model, runtime and benchmark."""
