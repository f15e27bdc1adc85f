"""Training (DQN, bag replay), vector policies, evaluation, the clairvoyant bound and the report."""
