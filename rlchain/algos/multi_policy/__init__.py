"""Multi-policy PPO: one learner per policy, snapshots of opponents, masked losses."""
