"""RLlib's Tune page: tune.Tuner("PPO", param_space=config) on the real Ray Tune."""
import ray
from ray import tune
from ray.rllib.algorithms.ppo import PPOConfig

ray.init(num_cpus=1, include_dashboard=False)
config = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1)
          .training(lr=tune.grid_search([1e-3, 3e-4]), train_batch_size=128, minibatch_size=64, num_epochs=1))
tuner = tune.Tuner("PPO", param_space=config,
                   run_config=tune.RunConfig(stop={"training_iteration": 2}, verbose=0))
results = tuner.fit()
assert not results.errors, results.errors
assert len(results) == 2
for result in results:
    assert result.metrics["training_iteration"] == 2, result.metrics
    assert result.metrics["num_env_steps_sampled_lifetime"] == 256
    assert "episode_return_mean" in result.metrics["env_runners"]
ray.shutdown()
print("OK")
