"""SAC's critic loss: the squared error by default, RLlib's Huber loss (delta 1) with ``loss: huber``."""

import pytest

from rlchain.algos.off_policy.sac_agent import SACAgent
from tests.unit.test_sac_dqn import batch, sac_model


@pytest.mark.parametrize("loss", ["mse", "huber"])
def test_critic_loss_is_the_configured_td_loss(loss):
    model, cfg = sac_model(loss=loss)
    data = batch()
    data["rewards"] = data["rewards"] * 100 + 50  # every TD error far above 1: Huber is |e| - 0.5 there
    stats, td = SACAgent(model, cfg).update(data)  # td: the mean of the two critics' |errors| per sample
    huber = float(2 * td.mean() - 1)  # mean over samples of (|e1| - 0.5) + (|e2| - 0.5)
    if loss == "huber":
        assert float(stats["critic_loss"]) == pytest.approx(huber, rel=1e-5)
    else:
        assert float(stats["critic_loss"]) > 10 * huber  # squared errors of about 50 and more
