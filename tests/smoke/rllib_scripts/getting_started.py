"""RLlib's getting-started page as a user writes it: config, build_algo, a train loop, a checkpoint, inference."""
import sys

import torch
from ray.rllib.algorithms.algorithm import Algorithm
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.columns import Columns

config = (
    PPOConfig()
    .environment("CartPole-v1")
    .env_runners(num_env_runners=1)
    .training(lr=3e-4, train_batch_size=256, minibatch_size=64, num_epochs=2)
)
algo = config.build_algo()
for _ in range(2):
    result = algo.train()
print("return", result["env_runners"]["episode_return_mean"], "steps", result["num_env_steps_sampled_lifetime"])
assert result["training_iteration"] == 2 and result["num_env_steps_sampled_lifetime"] == 512
for key in ("policy_loss", "vf_loss", "entropy", "mean_kl_loss", "curr_lr"):
    assert key in result["learners"]["default_policy"], key
assert result["episode_reward_mean"] == result["env_runners"]["episode_return_mean"]
path = algo.save_to_path(sys.argv[1])
out = algo.get_module().forward_inference({Columns.OBS: torch.zeros(5, 4)})
assert out[Columns.ACTION_DIST_INPUTS].shape == (5, 2)
action = algo.compute_single_action([0.0, 0.0, 0.0, 0.0], explore=False)
assert action in (0, 1)
evaluation = algo.evaluate()
assert evaluation["env_runners"]["num_episodes"] == 10
algo.stop()

restored = Algorithm.from_checkpoint(path)
assert restored.iteration == 2
after = restored.get_module().forward_inference({"obs": torch.zeros(5, 4)})["action_dist_inputs"]
assert torch.allclose(after, out[Columns.ACTION_DIST_INPUTS])
assert restored.train()["num_env_steps_sampled_lifetime"] == 768  # resumed: counters restored
restored.stop()
print("OK")
