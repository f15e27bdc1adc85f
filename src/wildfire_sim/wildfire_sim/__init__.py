"""Stochastic wildfire model (batched) and the fire-simulator node."""
