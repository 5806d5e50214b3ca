"""RLlib's connectors: only ``env_to_module.MeanStdFilter`` (rlchain's observation normalizer, see
:mod:`rlchain.rllib.obs_filter`); every other connector is a one-line ImportError."""
