"""``ray.rllib.policy.sample_batch``: ``SampleBatch`` as RLlib's modules use it, a dict with the column names."""

from rlchain.rllib.core import DEFAULT_POLICY_ID
from rlchain.rllib.core.columns import Columns


class SampleBatch(dict):
    """A dict of columns; the class attributes are RLlib's column names."""

    OBS = Columns.OBS
    NEXT_OBS = Columns.NEXT_OBS
    ACTIONS = Columns.ACTIONS
    REWARDS = Columns.REWARDS
    TERMINATEDS = Columns.TERMINATEDS
    TRUNCATEDS = Columns.TRUNCATEDS
    INFOS = Columns.INFOS
    ACTION_DIST_INPUTS = Columns.ACTION_DIST_INPUTS
    ACTION_LOGP = Columns.ACTION_LOGP
    VF_PREDS = Columns.VF_PREDS


__all__ = ["DEFAULT_POLICY_ID", "SampleBatch"]
