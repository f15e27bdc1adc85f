"""Benchmarks behind `wildfire bench`: each module measures one part of the real system."""
