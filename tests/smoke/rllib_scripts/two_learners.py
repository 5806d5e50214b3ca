# An RLlib script with two learners: launched by torchrun, one process per learner (tests/smoke/test_rllib_learners.py).
from ray.rllib.algorithms.ppo import PPOConfig

config = (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1).learners(num_learners=2)
          .training(train_batch_size=256, minibatch_size=64, num_epochs=2).debugging(seed=0))
algo = config.build_algo()
for _ in range(2):
    result = algo.train()
weights = sum(float(p.sum()) for p in algo.get_module().model.parameters())
print("iteration", result["training_iteration"], "lifetime", result["num_env_steps_sampled_lifetime"],
      "weights", round(weights, 5))
algo.stop()
print("OK")
