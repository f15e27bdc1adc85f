"""Shared belief map, visit update, team reward and the belief-aggregator node."""
