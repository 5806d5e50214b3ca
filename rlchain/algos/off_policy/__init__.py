"""Off-policy algorithms: the replay loop, SAC, DQN and hindsight relabelling (HER)."""
