"""Ray Tune search files (backend: ray) without Ray: bad input is one line, a PBT schedule replays
through set_params, and the trial's epoch stepper loads checkpoints and sets live values for PPO,
SAC and DQN alike (what PBT's exploit and explore steps do)."""

import os
import sys

import pytest
import yaml

from rlchain.config.errors import ConfigError
from rlchain.runner import Runner
from rlchain.training.events import Callback
from rlchain.tuning import ray_search
from rlchain.tuning.common import load_search
from rlchain.tuning.epochs import EpochStepper
from tests.conftest import CONFIGS

CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
SMALL = ["params.config.num_actors=8", "params.config.minibatch_size=64"]
PBT = {"interval_epochs": 4,
       "mutations": {"params.config.learning_rate": {"type": "loguniform", "low": 1e-5, "high": 1e-2}}}


def _search(tmp_path, **keys):
    raw = {"base": CARTPOLE, "backend": "ray", "trials": 4, "concurrent": 2, "scheduler": "pbt", "pbt": PBT,
           "ray": {"num_cpus": 2}, **keys}
    path = tmp_path / "search.yaml"
    path.write_text(yaml.safe_dump(raw))
    return str(path)


def _mutation(key, dist=None):
    return {**PBT, "mutations": {key: dist or {"type": "uniform", "low": 0.0, "high": 1.0}}}


@pytest.mark.parametrize("keys, match", [
    ({"scheduler": "hyperband"}, r"search.yaml: scheduler: unknown scheduler 'hyperband' \(valid: fifo, asha, pbt\)"),
    ({"searcher": "bayes", "scheduler": "fifo"}, r"search.yaml: searcher: unknown searcher 'bayes'"),
    ({"searcher": "optuna"}, r"search.yaml: searcher: pbt samples its own population"),
    ({"backend": "spark"}, r"search.yaml: backend: 'spark' is not one of optuna, ray"),
    ({"concurrent": 0}, r"search.yaml: concurrent: expected an integer >= 1"),
    ({"pbt": {**PBT, "quantile": 0.7}}, r"search.yaml: pbt.quantile: expected a number >= .* and <= 0.5"),
    ({"pbt": {"interval_epochs": 4}}, r"search.yaml: pbt.mutations: required"),
    ({"asha": {"grace_epochs": 2}}, r"search.yaml: asha: only with scheduler: asha"),
    ({"ray": {"adress": "auto"}}, r"search.yaml: ray.adress: unknown key \(valid: address, num_cpus, storage_path\)"),
])
def test_bad_ray_keys_are_one_line(tmp_path, keys, match):
    with pytest.raises(ConfigError, match=match) as info:
        load_search(_search(tmp_path, **keys))
    assert "\n" not in str(info.value)


def test_ray_keys_need_backend_ray(tmp_path):
    path = tmp_path / "search.yaml"
    path.write_text(yaml.safe_dump({"base": CARTPOLE, "scheduler": "pbt",
                                    "params": {"params.config.gamma": {"type": "uniform", "low": 0.9, "high": 0.99}}}))
    with pytest.raises(ConfigError, match=r"search.yaml: scheduler: only with backend: ray"):
        load_search(str(path))


@pytest.mark.parametrize("keys, match", [
    # a mutation key that does not exist: the config's own did-you-mean
    ({"pbt": _mutation("params.config.lerning_rate")},
     r"search.yaml: pbt.mutations.params.config.lerning_rate: value 0.0 is rejected: .*lerning_rate.*learning_rate"),
    # one that exists but cannot change live
    ({"pbt": _mutation("params.config.num_actors", {"type": "int", "low": 8, "high": 64})},
     r"search.yaml: pbt.mutations.params.config.num_actors: cannot change live for a2c_discrete: PBT changes "
     r"only the algorithm's tunable params.config keys \(learning_rate, entropy_coef, e_clip"),
    ({"pbt": _mutation("params.network.mlp.units", {"type": "categorical", "choices": [[32], [64]]})},
     r"search.yaml: pbt.mutations.params.network.mlp.units: cannot change live"),
    ({"concurrent": 3}, r"search.yaml: concurrent: 3 trials x 1 CPUs need 3 CPUs but this machine has 2; lower "
                        r"concurrent or resources.cpus"),
    ({"scheduler": "fifo", "searcher": "grid", "pbt": None,
      "params": {"params.config.gamma": {"type": "uniform", "low": 0.9, "high": 0.99}}},
     r"search.yaml: params.params.config.gamma: searcher grid needs categorical or int values"),
])
def test_bad_search_is_one_line_before_ray_starts(tmp_path, keys, match):
    keys = {k: v for k, v in keys.items() if v is not None}
    raw_keys = dict(keys)
    if keys.get("scheduler") == "fifo":
        raw = yaml.safe_load(open(_search(tmp_path, **raw_keys)))
        raw.pop("pbt")
        (tmp_path / "search.yaml").write_text(yaml.safe_dump(raw))
        path = str(tmp_path / "search.yaml")
    else:
        path = _search(tmp_path, **raw_keys)
    with pytest.raises(ConfigError, match=match) as info:
        ray_search.validate(load_search(path))
    assert "\n" not in str(info.value)


def test_sac_mutations_are_its_own_tunables(tmp_path):
    sac = os.path.join(CONFIGS, "sac_pendulum.yaml")
    ok = _search(tmp_path, base=sac, pbt=_mutation("params.config.actor_lr", {"type": "loguniform", "low": 1e-5,
                                                                              "high": 1e-3}))
    ray_search.validate(load_search(ok))
    bad = _search(tmp_path, base=sac, pbt=_mutation("params.config.init_alpha",
                                                    {"type": "loguniform", "low": 0.1, "high": 1.0}))
    with pytest.raises(ConfigError, match=r"cannot change live for sac: .*\(actor_lr, critic_lr"):
        ray_search.validate(load_search(bad))


def test_missing_ray_is_one_line(monkeypatch, tmp_path, capsys):
    import builtins

    real = builtins.__import__

    def no_ray(name, *args, **kwargs):
        if name == "ray" or name.startswith("ray."):
            raise ImportError(f"No module named '{name}'")
        return real(name, *args, **kwargs)

    for name in [m for m in sys.modules if m == "ray" or m.startswith("ray.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(builtins, "__import__", no_ray)
    with pytest.raises(ImportError, match=r"^Ray Tune is not installed: pip install rlchain\[ray\]$"):
        ray_search.import_ray_tune()
    from rlchain.tuning.search import main

    assert main([_search(tmp_path), "-o", str(tmp_path / "best.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "error: Ray Tune is not installed: pip install rlchain[ray]"


class _Record(Callback):
    def __init__(self):
        self.lr = []

    def on_epoch_end(self, ctx, stats, episodes):
        self.lr.append(ctx.get_params()["learning_rate"])


def test_hyperparam_schedule_replays_through_set_params(tmp_path):
    record = _Record()
    schedule = "params.config.hyperparam_schedule={0: {learning_rate: 0.002}, 2: {learning_rate: 0.0005}}"
    Runner().load(CARTPOLE, ["params.config.max_epochs=3", "params.config.lr_schedule=None", *SMALL,
                             "params.config.print_stats=false", f"params.config.train_dir={tmp_path}", schedule]
                  ).train(callbacks=[record])
    assert record.lr == pytest.approx([0.002, 0.002, 0.0005])


def test_hyperparam_schedule_names_must_be_tunable(tmp_path):
    runner = Runner().load(CARTPOLE, ["params.config.max_epochs=1", f"params.config.train_dir={tmp_path}",
                                      "params.config.hyperparam_schedule={0: {num_actors: 4}}"])
    with pytest.raises(ConfigError, match=r"params.config.hyperparam_schedule.0.num_actors: 'num_actors' cannot "
                                          r"change live for a2c_discrete \(tunable: learning_rate"):
        runner.train()
    with pytest.raises(ConfigError, match=r"hyperparam_schedule: epoch -1: expected an integer >= 0"):
        Runner().load(CARTPOLE, ["params.config.hyperparam_schedule={-1: {learning_rate: 0.1}}"])


@pytest.mark.parametrize("config, overrides, name, value", [
    ("ppo_cartpole.yaml", ["params.config.lr_schedule=None", "params.config.num_actors=8",
                           "params.config.minibatch_size=64"], "entropy_coef", 0.005),
    ("sac_pendulum.yaml", ["params.config.num_warmup_frames=100", "params.config.num_steps_per_episode=10"],
     "critic_lr", 1e-4),
    ("dqn_cartpole.yaml", ["params.config.num_warmup_frames=100", "params.config.num_steps_per_episode=10"],
     "learning_rate", 2e-4),
])
def test_stepper_exploit_and_explore_for_every_algorithm(tmp_path, config, overrides, name, value):
    """What a PBT exploit does in a trial: save between epochs, later load that checkpoint into the
    running envs (the counters go back), set a perturbed value live; the next epoch trains with it."""
    runner = Runner().load(os.path.join(CONFIGS, config), overrides + [
        "params.config.print_stats=false", f"params.config.train_dir={tmp_path}", "params.config.max_epochs=50"])
    stepper = EpochStepper(runner, seed=1)
    try:
        first = stepper.next_epoch()
        assert first.epoch == 1 and name in first.params
        stepper.save(str(tmp_path / "donor.pth"))
        assert stepper.next_epoch().epoch == 2
        env = stepper.context.training_env
        stepper.load(str(tmp_path / "donor.pth"))
        stepper.set_params({name: value})
        after = stepper.next_epoch()
        assert after.epoch == 2 and after.frames == 2 * first.frames  # resumed from epoch 1
        assert after.params[name] == pytest.approx(value) and stepper.context.training_env is env  # same envs
    finally:
        stepper.shutdown()
    assert stepper.result is None or stepper.result.epoch >= 2


def test_shipped_pbt_search_is_valid():
    spec = load_search(os.path.join(CONFIGS, "tune", "pbt_cartpole.yaml"))
    assert spec.backend == "ray" and spec.ray.scheduler == "pbt" and spec.ray.concurrent == 2
    assert set(spec.ray.pbt.mutations) == {"params.config.learning_rate", "params.config.entropy_coef"}
    ray_search.validate(spec)


def test_pbt_perturbations_stay_in_their_range():
    mutations = {"params.config.gamma": {"type": "uniform", "low": 0.9, "high": 0.999, "log": False},
                 "params.config.mini_epochs": {"type": "int", "low": 1, "high": 8, "log": False}}
    clipped = ray_search.clip_to_ranges({"params.config.gamma": 0.99 * 1.2, "params.config.mini_epochs": 0,
                                         "params.config.e_clip": 5.0}, mutations)
    assert clipped == {"params.config.gamma": 0.999, "params.config.mini_epochs": 1, "params.config.e_clip": 5.0}
