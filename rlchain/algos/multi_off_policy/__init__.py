"""Multi-policy DQN and SAC: each policy its own off-policy agent over one PettingZoo vector env."""
