"""Dubins aircraft, sensor model, rewards, policies (TorchScript, receding horizon, random) and the agent node."""
