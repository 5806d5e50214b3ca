"""SAC's target critic moves toward the critic by critic_tau, not by 1 - critic_tau (a tau of 0.5, where the two
are equal, cannot tell them apart)."""

import torch

from rlchain.algos.off_policy.sac_agent import SACAgent
from tests.unit.test_sac_dqn import batch, sac_model


def test_target_critic_moves_by_tau_toward_the_critic():
    model, cfg = sac_model(critic_tau=0.1)
    agent = SACAgent(model, cfg)
    before = [p.clone() for p in model.critic_target.parameters()]
    agent.update(batch())
    for b, t, p in zip(before, model.critic_target.parameters(), model.network.critic.parameters()):
        assert torch.allclose(t, 0.9 * b + 0.1 * p, atol=1e-6)
