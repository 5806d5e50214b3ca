"""Off-policy algorithms: SAC, DQN, hindsight relabelling (HER) and their trainer."""
