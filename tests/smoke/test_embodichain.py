"""EmbodiChain-layout configs train end to end (rlchain/config/embodichain.py): train.py --config and
rlchain train, their TensorBoard tags beside rlchain's, events applied, the rl_games-style config saved."""

import glob
import json
import os
import sys

import torch
import yaml

from rlchain import Runner
from rlchain.training.events import Callback
from tests.conftest import ROOT
from tests.smoke.cli_server import run_python

CALLS = []
REFERENCES = []


def tick(env, env_ids, **params):
    """A user train event (named in the config below)."""
    CALLS.append((type(env).__name__, env_ids, params))


def layout(tmp_path, algo="ppo", gym_config="EmbodiChainPushStandIn", save_freq=0):
    actor = {"type": "mlp", "network_cfg": {"hidden_sizes": [16], "activation": "tanh"}}
    policy = {"name": "actor_critic", "actor": actor, "critic": actor} if algo == "ppo" else \
        {"name": "actor_only", "actor": actor}
    cfg = {"optimizer": {"name": "adam", "learning_rate": 1e-3}, "n_epochs": 1, "batch_size": 128}
    if algo == "grpo":
        cfg.update(group_size=4, kl_coef=0.01)
    trainer = {"exp_name": f"ec_{algo}", "gym_config": gym_config, "seed": 1, "device": "cpu", "num_envs": 8,
               "iterations": 2, "buffer_size": 16, "enable_eval": True, "eval_freq": 128, "num_eval_envs": 2,
               "num_eval_episodes": 2, "save_freq": save_freq,
               "events": {"train": {"tick": {"func": "tests.smoke.test_embodichain.tick", "interval_step": 8,
                                             "params": {"x": 1}}}}}
    path = tmp_path / "train_config.json"
    path.write_text(json.dumps({"trainer": trainer, "policy": policy, "algorithm": {"name": algo, "cfg": cfg}}))
    return str(path)


def test_runs_with_their_tags_events_and_saved_config(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    CALLS.clear()
    result = Runner().load(layout(tmp_path), [f"params.config.train_dir={tmp_path}/runs"]).train()
    assert result.frames == 2 * 16 * 8
    tags = set()
    for folder in glob.glob(os.path.join(result.run_dir, "summaries")):
        events = EventAccumulator(folder)
        events.Reload()
        tags |= set(events.Tags()["scalars"])
    assert {"rewards/goal_distance_reward", "rewards/success_bonus", "metrics/distance_to_goal", "charts/SPS",
            "eval/avg_reward", "eval/success_rate", "train/a_loss", "losses/a_loss"} <= tags, sorted(tags)
    assert len(CALLS) == 4 and CALLS[0] == ("PushStandIn", None, {"x": 1})  # 32 env steps, every 8th
    saved = glob.glob(os.path.join(result.run_dir, "*.yaml"))
    assert saved and "params" in yaml.safe_load(open(saved[0]))


def test_checkpoints_carry_their_names_and_keys_and_play_and_resume(tmp_path):
    from rlchain.runs import checkpoint as ckpt

    path = layout(tmp_path, save_freq=100)  # 128 env steps an epoch: a save after epochs 1 and 2
    result = Runner().load(path, [f"params.config.train_dir={tmp_path}/runs"]).train()
    nn = os.path.join(result.run_dir, "nn")
    assert sorted(os.listdir(nn)) == ["ec_ppo_best.pt", "ec_ppo_step_128.pt", "ec_ppo_step_256.pt"]
    state = ckpt.load(os.path.join(nn, "ec_ppo_step_128.pt"))
    assert state["global_step"] == 128 and state["optimizer"]["state"]
    assert all(torch.equal(v, state["model"][k]) for k, v in state["policy"].items())
    assert Runner().load(path).play(os.path.join(nn, "ec_ppo_best.pt"), games=2, quiet=True).games == 2
    resumed = Runner().load(path, [f"params.config.train_dir={tmp_path}/again"]).train(
        checkpoint=os.path.join(nn, "ec_ppo_step_128.pt"))
    assert resumed.frames == 256 and "ec_ppo_step_256.pt" in os.listdir(os.path.join(resumed.run_dir, "nn"))


class KeepReference(Callback):
    """Test-only: keeps GRPO's frozen reference policy at the end of training."""

    def on_train_end(self, ctx, result):
        REFERENCES.append({k: v.clone() for k, v in ctx.algorithm.reference.state_dict().items()})


def test_grpo_resume_keeps_the_reference_policy(tmp_path):
    from rlchain.runs import checkpoint as ckpt

    REFERENCES.clear()
    path = layout(tmp_path, "grpo", "EmbodiChainCartPoleStandIn", save_freq=100)
    first = Runner().load(path, [f"params.config.train_dir={tmp_path}/runs"]).train(callbacks=[KeepReference()])
    step = os.path.join(first.run_dir, "nn", "ec_grpo_step_128.pt")
    saved = ckpt.load(step)["grpo_reference"]
    assert all(torch.equal(v, REFERENCES[0][k]) for k, v in saved.items())  # the initial policy, kept
    Runner().load(path, [f"params.config.train_dir={tmp_path}/again"]).train(checkpoint=step,
                                                                           callbacks=[KeepReference()])
    assert all(torch.equal(v, REFERENCES[1][k]) for k, v in saved.items())


def test_train_py_grpo(tmp_path):
    path = layout(tmp_path, "grpo", "EmbodiChainCartPoleStandIn")
    out = run_python([sys.executable, os.path.join(ROOT, "train.py"), "--config", path,
                      f"params.config.train_dir={tmp_path}/runs", "params.torch_threads=1"], os.getcwd(),
                     {**os.environ, "PYTHONPATH": ROOT}, 120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "training grpo on EmbodiChainCartPoleStandIn" in out.stdout + out.stderr
    assert "algo:\n    name: grpo" in out.stdout + out.stderr  # the rl_games-style config it runs


def test_rlchain_train_and_the_dexsim_error(tmp_path, capsys):
    from rlchain.console import main

    path = layout(tmp_path, "grpo", "EmbodiChainCartPoleStandIn")
    assert main(["train", path, f"params.config.train_dir={tmp_path}/runs"]) == 0
    gym = tmp_path / "gym_config.json"
    gym.write_text(json.dumps({"id": "PushCubeRL"}))
    assert main(["train", layout(tmp_path, gym_config=str(gym))]) == 2
    assert "task 'PushCubeRL'" in capsys.readouterr().err


def test_rlchain_benchmark_writes_its_report(tmp_path):
    from rlchain.console import main

    path = layout(tmp_path, "grpo", "EmbodiChainCartPoleStandIn")
    out = tmp_path / "bench"
    assert main(["benchmark", path, "--seeds", "0", "--threshold", "0.0", "--out", str(out),
                 "trainer.events={}", "params.torch_threads=1"]) == 0
    report = json.loads((out / "report.json").read_text())
    (run,) = report["runs"]
    assert run["status"] == 0 and run["final_success_rate_stable"] is not None and run["peak_memory_mb"] > 0
    assert run["peak_memory_kind"] == "cpu_rss" and run["gpu_peak_memory_mb"] is None
    assert run["steps_to_success_threshold"] is None  # two evaluations: never 3 in a row
    assert report["leaderboard"][0]["algorithm"] == "grpo"
    assert "| EmbodiChainCartPoleStandIn | grpo | 1 |" in (out / "report.md").read_text()
