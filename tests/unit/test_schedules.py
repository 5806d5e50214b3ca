"""Learning-rate and entropy schedules (rlchain/algos/core/schedules.py) and how the PPO agent applies them."""

import copy
import warnings

import pytest
import torch

from rlchain.algos.core.schedules import (
    MIN_ENTROPY_COEF,
    ConstantSchedule,
    LinearSchedule,
    PolynomialSchedule,
    linear_decay,
    make_schedule,
    polynomial_decay,
    scale_lr,
    scheduled_entropy_coef,
    set_lr,
)
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.config import ConfigError, compat, parse_params
from rlchain.config.compat import RlchainDeprecationWarning
from rlchain.runs.logging import TrainLogger


def parse(cfg, **config):
    """``cfg`` (left as it is) with ``config`` keys set, parsed."""
    cfg = copy.deepcopy(cfg)
    cfg["params"]["config"].update(config)
    return parse_params(cfg, "cfg.yaml")


@pytest.fixture(autouse=True)
def fresh_warnings(monkeypatch):
    """Each test sees its config warnings, though compat warns once per process."""
    monkeypatch.setattr(compat, "_warned", set())


def agent_for(base_config, **config):
    """A PPO agent over a stand-in model: the schedules need only its parameters."""
    return PPOAgent(torch.nn.Linear(2, 2), parse(base_config, **config).config, torch.device("cpu"))


# ----- pure functions, against values worked out by hand ---------------------------------------
def test_polynomial_decay_hand_values():
    # 1e-5 + (1e-3 - 1e-5) * 0.75 ** 2 = 1e-5 + 9.9e-4 * 0.5625
    assert polynomial_decay(1e-3, 1e-5, 0.25, 2.0) == pytest.approx(5.66875e-4)
    # 0 + 1.0 * 0.5 ** 0.5
    assert polynomial_decay(1.0, 0.0, 0.5, 0.5) == pytest.approx(0.7071067811865476)
    assert polynomial_decay(1e-3, 1e-5, 0.0, 3.0) == pytest.approx(1e-3)
    assert polynomial_decay(1e-3, 1e-5, 1.0, 3.0) == pytest.approx(1e-5)
    assert polynomial_decay(1e-3, 1e-5, 1.7, 3.0) == pytest.approx(1e-5)  # past the end: stays at the floor
    assert polynomial_decay(1e-3, 1e-5, -0.5, 3.0) == pytest.approx(1e-3)


def test_linear_decay_is_power_one_and_matches_rl_games_linear_scheduler():
    # rl_games LinearScheduler at epoch 30 of 120: mul = (120 - 30) / 120 = 0.75
    assert linear_decay(3e-4, 1e-6, 30 / 120) == pytest.approx(1e-6 + (3e-4 - 1e-6) * 0.75)
    for progress in (0.0, 0.3, 0.9, 1.0):
        assert linear_decay(2.0, 0.5, progress) == pytest.approx(polynomial_decay(2.0, 0.5, progress, 1.0))


def test_scheduled_entropy_coef_hand_values():
    assert MIN_ENTROPY_COEF == 1e-4
    assert scheduled_entropy_coef(0.01, 0.0) == pytest.approx(0.01)
    assert scheduled_entropy_coef(0.01, 0.5) == pytest.approx(1e-4 + 0.0099 * 0.5)  # 0.00505
    assert scheduled_entropy_coef(0.01, 1.0) == pytest.approx(1e-4)
    assert scheduled_entropy_coef(0.01, 2.0) == pytest.approx(1e-4)
    # rl_games' formula, kept as is: a start below the floor rises to it
    assert scheduled_entropy_coef(0.0, 0.5) == pytest.approx(5e-5)


def test_polynomial_schedule_and_make_schedule():
    s = make_schedule("polynom_decay", 1e-3, 0.008, 1e-5, 1e-2, decay_power=2.0)
    assert s == PolynomialSchedule(1e-3, 1e-5, 2.0)
    assert s.update(7e-4, kl=0.5) == 7e-4  # per-minibatch calls (KL only) leave it alone
    assert s.update(7e-4, progress=0.25) == pytest.approx(5.66875e-4)
    assert isinstance(make_schedule("linear", 1e-3, 0.008, 0.0, 1e-2), LinearSchedule)
    assert isinstance(make_schedule(None, 1e-3, 0.008, 0.0, 1e-2), ConstantSchedule)


# ----- the agent ---------------------------------------------------------------------------------
def test_agent_applies_polynom_decay_after_each_epoch(base_config):
    agent = agent_for(base_config, lr_schedule="polynom_decay", learning_rate=1e-3, min_lr=1e-5,
                      decay_power=2.0, max_epochs=8)
    assert agent.lr == pytest.approx(1e-3)
    agent.apply_progress(2 / 8)
    assert agent.lr == pytest.approx(5.66875e-4)
    assert all(g["lr"] == pytest.approx(5.66875e-4) for g in agent.optimizer.param_groups)


def test_agent_schedules_entropy_with_linear_lr(base_config):
    agent = agent_for(base_config, lr_schedule="linear", learning_rate=1e-3, min_lr=0.0, entropy_coef=0.01,
                      schedule_entropy=True, max_epochs=10)
    assert agent.entropy_coef == pytest.approx(0.01)
    agent.apply_progress(0.5)
    assert agent.entropy_coef == pytest.approx(0.00505)
    assert agent.lr == pytest.approx(5e-4)
    agent.apply_progress(1.0)
    assert agent.entropy_coef == pytest.approx(1e-4)


def test_agent_keeps_entropy_without_linear_lr(base_config):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RlchainDeprecationWarning)
        agent = agent_for(base_config, lr_schedule="adaptive", entropy_coef=0.01, schedule_entropy=True,
                          max_epochs=10)
    agent.apply_progress(0.5)
    assert agent.entropy_coef == 0.01
    constant = agent_for(base_config, lr_schedule="linear", entropy_coef=0.01, max_epochs=10)
    constant.apply_progress(0.5)
    assert constant.entropy_coef == 0.01  # schedule_entropy off: only the lr moves


def test_agent_state_carries_entropy_coef(base_config):
    cfg = dict(lr_schedule="linear", learning_rate=1e-3, entropy_coef=0.01, schedule_entropy=True, max_epochs=4)
    agent = agent_for(base_config, **cfg)
    agent.apply_progress(0.75)
    state = agent.state_dict()
    assert state["entropy_coef"] == pytest.approx(1e-4 + 0.0099 * 0.25)
    fresh = agent_for(base_config, **cfg)
    fresh.load_state_dict(state)
    assert fresh.entropy_coef == state["entropy_coef"] and fresh.lr == state["lr"]
    old = {k: v for k, v in state.items() if k != "entropy_coef"}  # a checkpoint from before the key
    older = agent_for(base_config, **cfg)
    older.load_state_dict(old)
    assert older.entropy_coef == 0.01


def test_logger_writes_entropy_coef():
    from rlchain.algos.ppo.ppo import PPO
    from rlchain.runs.writers import Writer
    from rlchain.training.loop import tag_metrics

    class Recorder(Writer):
        def __init__(self):
            self.tags = {}

        def write(self, scalars, step):
            self.tags.update(scalars)

    recorder = Recorder()
    logger = TrainLogger(None, print_stats=False, writers=[recorder])
    stats = {"a_loss": 0.0, "c_loss": 0.0, "entropy": 0.0, "b_loss": 0.0, "lr": 1e-3, "kl": 0.0,
             "clip_frac": 0.0, "grad_norm": 0.0, "entropy_coef": 0.005}
    metrics = tag_metrics(stats, PPO.metric_tags)
    logger.epoch(1, 10, 64, metrics, None, float("-inf"), {"batch": 64, "rollout": 0.1, "update": 0.1})
    assert recorder.tags["info/entropy_coef"] == 0.005


# ----- config: new keys, bad values, cross-key rules ------------------------------------------
@pytest.mark.parametrize("key,value,expect", [
    ("decay_power", -1.0, "must be > 0"),
    ("decay_power", 0, "must be > 0"),
    ("decay_power", "steep", "expected a number"),
    ("lr_schedule", "polynom_decy", "did you mean 'polynom_decay'"),
    ("schedule_entropy", "sometimes", "expected true or false"),
])
def test_bad_schedule_values_name_the_key(base_config, key, value, expect):
    with pytest.raises(ConfigError) as err:
        parse(base_config, **{"lr_schedule": "polynom_decay", "max_epochs": 10, key: value})
    msg = str(err.value)
    assert msg.startswith(f"cfg.yaml: params.config.{key}: ") and expect in msg and "\n" not in msg


def test_polynom_decay_needs_a_horizon(base_config):
    with pytest.raises(ConfigError) as err:
        parse(base_config, lr_schedule="polynom_decay")
    assert str(err.value) == ("cfg.yaml: params.config.lr_schedule: polynom_decay decays over the run: set "
                              "max_epochs or max_frames")
    assert parse(base_config, lr_schedule="polynom_decay", max_frames=1000).config.lr_schedule == "polynom_decay"


def test_polynom_decay_config_keys(base_config):
    cfg = parse(base_config, lr_schedule="polynom_decay", decay_power="2", min_lr="1e-7", max_epochs=5).config
    assert (cfg.lr_schedule, cfg.decay_power, cfg.min_lr) == ("polynom_decay", 2.0, 1e-7)


@pytest.mark.parametrize("schedule", ["adaptive", "None", "polynom_decay"])
def test_schedule_entropy_without_linear_lr_warns(base_config, schedule):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = parse(base_config, lr_schedule=schedule, schedule_entropy=True, entropy_coef=0.02, max_epochs=9)
    assert params.config.schedule_entropy is True
    texts = [str(w.message) for w in caught if issubclass(w.category, RlchainDeprecationWarning)]
    assert any(t.startswith("cfg.yaml: params.config.schedule_entropy: True has no effect with lr_schedule")
               and "entropy_coef stays 0.02" in t for t in texts), texts


def test_schedule_entropy_with_linear_is_quiet(base_config):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        parse(base_config, lr_schedule="linear", schedule_entropy=True, max_epochs=9)
    assert not [w for w in caught if "schedule_entropy" in str(w.message)]


def test_decay_power_without_polynom_decay_warns(base_config):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        parse(base_config, lr_schedule="linear", decay_power=3.0)
    assert any("params.config.decay_power: no effect with lr_schedule linear" in str(w.message) for w in caught)


def test_set_lr_and_scale_lr_reach_every_parameter_group():
    opt = torch.optim.Adam([{"params": [torch.zeros(1, requires_grad=True)]},
                            {"params": [torch.zeros(1, requires_grad=True)], "lr": 0.5}], lr=1e-3)
    scale_lr(opt, 0.5)
    assert [g["lr"] for g in opt.param_groups] == [5e-4, 0.25]
    set_lr(opt, 2e-4)
    assert [g["lr"] for g in opt.param_groups] == [2e-4, 2e-4]
