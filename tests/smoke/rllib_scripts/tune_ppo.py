"""RLlib's Tune pages: tune.Tuner("PPO", param_space=config) and the getting-started page's
tune.Tuner(config.algo_class, ...) with a grid search on the real Ray Tune, then the best trial's checkpoint
deployed as RLlib's RLModule.from_checkpoint(<checkpoint>/learner_group/learner/rl_module)."""
from pathlib import Path

import ray
import torch
from ray import tune
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module import RLModule

ray.init(num_cpus=1, include_dashboard=False)
config = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1)
          .training(train_batch_size=128, minibatch_size=64, num_epochs=1))
by_name = tune.Tuner("PPO", param_space=config, run_config=tune.RunConfig(stop={"training_iteration": 2}, verbose=0))
results = by_name.fit()
assert not results.errors and len(results) == 1, results.errors
assert results[0].metrics["training_iteration"] == 2, results[0].metrics
assert results[0].metrics["num_env_steps_sampled_lifetime"] == 256

config.training(lr=tune.grid_search([1e-3, 3e-4]))
tuner = tune.Tuner(config.algo_class, param_space=config,
                   run_config=tune.RunConfig(stop={"training_iteration": 2}, verbose=0))
results = tuner.fit()
assert not results.errors, results.errors
assert len(results) == 2
for result in results:
    assert result.metrics["training_iteration"] == 2, result.metrics
    assert result.metrics["num_env_steps_sampled_lifetime"] == 256
    assert "episode_return_mean" in result.metrics["env_runners"]
best = results.get_best_result(metric="env_runners/episode_return_mean", mode="max")
module = RLModule.from_checkpoint(Path(best.checkpoint.path) / "learner_group" / "learner" / "rl_module")
logits = module["default_policy"].forward_inference({"obs": torch.zeros(1, 4)})["action_dist_inputs"]
assert logits.shape == (1, 2), logits.shape
ray.shutdown()
print("OK")
