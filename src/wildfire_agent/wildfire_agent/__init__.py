"""Dubins aircraft, sensor model, rewards, pairwise states and policies (TorchScript,
receding horizon, random); the agent node."""
