"""``ray.rllib.policy``: of RLlib's old Policy API, only the names multi-agent scripts still pass as data
(``policy.PolicySpec``, ``sample_batch.SampleBatch`` column names); anything else is a one-line ImportError."""
