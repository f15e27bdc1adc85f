"""Batched multi-agent wildfire environment, DQN training, bag replay and evaluation."""
