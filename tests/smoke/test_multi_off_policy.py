"""Multi-policy DQN and SAC (config.multi_agent with algo dqn / sac): two policies train two epochs on a PettingZoo
env whose agents come and go, each with its own agent, replay buffer and tags; a checkpoint resumes and plays."""

import copy
import os

import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt

NETWORKS = {"dqn": {"name": "dqn", "space": {"discrete": None}, "mlp": {"units": [16]}},
            "sac": {"name": "soft_actor_critic", "separate": True, "space": {"discrete": None}, "mlp": {"units": [16]}}}
MODELS = {"dqn": "dqn", "sac": "soft_actor_critic"}
LOSSES = {"dqn": "td_loss", "sac": "critic_loss"}


def dying(algo, tmp_path=None, **config):
    raw = {"params": {
        "seed": 3, "algo": {"name": algo}, "model": {"name": MODELS[algo]}, "network": copy.deepcopy(NETWORKS[algo]),
        "config": {"name": "dying", "env_name": "pettingzoo", "device": "cpu", "num_actors": 2,
                   "env_config": {"env": "rlchain.envs.examples.pz_dying", "kwargs": {"runners": 2, "length": 6}},
                   "num_steps_per_episode": 20, "num_warmup_frames": 10, "batch_size": 8, "replay_buffer_size": 1000,
                   "max_epochs": 2, "print_stats": False, "save_best_after": 0, "player": {"games_num": 2},
                   "multi_agent": {"policies": {"runners": {}, "late": {"config": {"batch_size": 4, "gamma": 0.9,
                                                                              "n_step": 2, "n_step_max": 4}}},
                                   "policy_mapping": {"runner_*": "runners", "late_*": "late"}}}}}
    raw["params"]["config"].update(config)
    if tmp_path is not None:
        raw["params"]["config"]["train_dir"] = str(tmp_path)
    return raw


@pytest.mark.parametrize("algo", ["dqn", "sac"])
def test_two_policies_train_with_their_own_agents_and_buffers(tmp_path, algo):
    torch.set_num_threads(1)
    result = Runner().load(dying(algo, tmp_path)).train()
    assert (result.epoch, result.frames) == (2, 80)  # env steps x envs, not agent rows
    path = os.path.join(result.run_dir, "nn", "last_dying.pth")
    state = ckpt.load(path)
    assert {k.split(".")[0] for k in state["model"]} == {"runners", "late"}
    assert set(state["agent"]) == {"runners", "late"} and state["agent"]["late"]["updates"] > 0
    assert state["agent"]["runners"]["updates"] > 0
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    loss = LOSSES[algo]
    assert {f"losses/runners/{loss}", f"losses/late/{loss}", "info/late/replay_size", "rewards/late/iter",
            "rewards/runners/step"} <= tags
    resumed = Runner().load(dying(algo, tmp_path, max_epochs=3)).train(checkpoint=path)
    assert resumed.epoch == 3
    played = Runner().load(dying(algo)).play(path, quiet=True)
    assert set(played.mean_rewards) == {"runners", "late"}


@pytest.mark.parametrize("change, match", [
    (lambda c: c["multi_agent"].update(snapshots={"late": "runners"}, policies_to_train=["runners"]),
     r"multi_agent.snapshots: self-play snapshots"),
    (lambda c: c["multi_agent"]["policy_mapping"].update({"late_*": ["late", "runners"]}),
     r"multi_agent.policy_mapping.late_\*: a list of policies per episode is PPO only"),
    (lambda c: c["multi_agent"]["policies"]["late"]["config"].update(replay={"her": {}}),
     r"multi_agent.policies.late.config.replay.her: hindsight replay is single-agent only"),
    (lambda c: c["multi_agent"]["policies"]["late"]["config"].update(num_steps_per_episode=3),
     r"multi_agent.policies.late.config.num_steps_per_episode: is a run-level key"),
])
def test_what_multi_policy_dqn_does_not_do_yet_is_one_line(tmp_path, change, match):
    raw = dying("dqn", tmp_path)
    change(raw["params"]["config"])
    with pytest.raises(ConfigError, match=match):
        Runner().load(raw).train()
