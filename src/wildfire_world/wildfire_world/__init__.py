"""The batched world: fleets over fires, as vector and PettingZoo environments."""
