from ray.rllib.algorithms.ppo import PPOConfig

PPOConfig().environment("CartPole-v1").training(lr=1e-3, num_epoch=3)
