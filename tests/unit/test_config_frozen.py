"""The frozen config: parsing returns an immutable value with its derived keys filled in,
resolve() makes the per-process run context, checkpoints store the resolved config as data."""

import copy
import dataclasses
import os
import sys
import types
import warnings

import pytest
import torch.nn as nn

from rlchain import model_builder
from rlchain.config import ConfigError, parse_params
from rlchain.config.fields import option
from rlchain.config.load import import_user_modules, load_config
from rlchain.config.resolve import (
    RANK_SEED_STRIDE,
    ProcessContext,
    config_state,
    params_from_state,
    resolve,
    with_config,
)
from rlchain.networks.base import instantiate
from rlchain.runner import Runner
from tests.conftest import BASE, CONFIGS


def parse(**config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update(config)
    return parse_params(raw, "cfg.yaml")


def test_every_parsed_block_refuses_assignment():
    params = parse(central_value_config={"network": {"mlp": {"units": [8]}}})
    for obj, name in [(params, "seed"), (params.config, "learning_rate"), (params.config, "minibatch_size"),
                      (params.config.player, "games_num"), (params.config.central_value_config, "minibatch_size"),
                      (params.network, "separate"), (params.network.mlp, "units"), (params.algo, "name")]:
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, name, getattr(obj, name))
    for config in ("sac_pendulum.yaml", "dqn_cartpole.yaml", "appo_cartpole.yaml", "impala_cartpole.yaml"):
        cfg = load_config(os.path.join(CONFIGS, config)).config
        with pytest.raises(dataclasses.FrozenInstanceError):
            cfg.num_actors = 2


def test_derived_keys_are_filled_in_by_parsing_not_by_assignment():
    params = parse(minibatch_size=None, minibatch_size_per_env=4, lr_schedule="constant",
                   central_value_config={"network": {"mlp": {"units": [8]}}, "minibatch_size_per_env": 2})
    cfg = params.config
    assert cfg.minibatch_size == 16 and cfg.lr_schedule is None
    assert cfg.central_value_config.minibatch_size == 8
    assert type(cfg.central_value_config.network).__name__ == "NetworkConfig"  # parsed like params.network
    impala = load_config(os.path.join(CONFIGS, "impala_cartpole.yaml")).config
    assert impala.mini_epochs == 1
    sac = load_config(os.path.join(CONFIGS, "sac_pendulum.yaml"), ["params.config.num_warmup_frames=None",
                                                                   "params.config.num_warmup_steps=3"]).config
    assert sac.num_warmup_frames == 3 * sac.num_actors * sac.num_steps_per_episode


def test_multi_agent_policies_are_frozen_too():
    pytest.importorskip("pettingzoo")
    params = load_config(os.path.join(CONFIGS, "ppo_pz_simple_tag.yaml"))
    assert params.policies
    for policy in params.policies.values():
        with pytest.raises(dataclasses.FrozenInstanceError):
            policy.config.learning_rate = 1.0


class FakeGroup:
    """What resolve() reads of a torchrun group (rlchain.parallel.distributed.Distributed)."""

    def __init__(self, rank, device=None):
        self.rank, self.world_size, self.device = rank, 2, device
        self.rank_seed = 7 + rank * RANK_SEED_STRIDE


def test_resolve_makes_the_per_process_context_and_leaves_the_parsed_config_alone():
    params = parse(device="cuda:0", env_config={"seed": 5, "device": "cuda:0"})
    single = resolve(params, 3)
    assert single == ProcessContext(params, 3) and single.params is params and single.params.config.print_stats
    assert isinstance(resolve(params, None).seed, int)  # drawn when none is given

    rank1 = resolve(params, 7, FakeGroup(1, device="cuda:1"))
    assert rank1.seed == 7 + RANK_SEED_STRIDE and rank1.rank == 1 and rank1.world_size == 2
    assert rank1.params.config.device == "cuda:1" and rank1.params.config.print_stats is False
    assert rank1.params.config.env_config == {"seed": 5 + RANK_SEED_STRIDE, "device": "cuda:1"}
    rank0 = resolve(params, 7, FakeGroup(0))  # gloo: no device of its own; rank 0 prints
    cfg0 = rank0.params.config
    assert cfg0.device == "cuda:0" and cfg0.print_stats and cfg0.env_config["seed"] == 5
    # the parsed value is untouched
    assert params.config.device == "cuda:0" and params.config.print_stats
    assert params.config.env_config == {"seed": 5, "device": "cuda:0"}


def test_with_config_changes_every_policy():
    pytest.importorskip("pettingzoo")
    params = load_config(os.path.join(CONFIGS, "ppo_pz_simple_tag.yaml"))
    quiet = with_config(params, print_stats=False)
    assert not quiet.config.print_stats and all(not p.config.print_stats for p in quiet.policies.values())
    assert params.config.print_stats and with_config(params) is params


@pytest.mark.parametrize("config, overrides", [
    ("ppo_cartpole.yaml", []),
    ("ppo_cartpole_masked_velocity_rnn.yaml", []),
    ("ppo_pong_envpool.yaml", []),  # cnn convs, a list of blocks
    ("sac_pendulum.yaml", []),
    ("dqn_cartpole.yaml", []),
    ("appo_cartpole.yaml", []),  # keys that are an error in an appo file are stored at their defaults
    ("impala_cartpole.yaml", []),
    ("sac_her_fetch_reach.yaml", []),
    ("ppo_cartpole.yaml", ["params.config.minibatch_size=null", "params.config.minibatch_size_per_env=8",
                           "params.config.torch_compile={mode: reduce-overhead}",
                           "params.config.central_value_config={network: {mlp: {units: [8]}}}"]),
])
def test_the_checkpointed_config_reads_back_equal(config, overrides):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rl_games no-op keys in shipped configs
        params = load_config(os.path.join(CONFIGS, config), overrides)
    state = config_state(params, {"seed": 1})
    assert state["run"] == {"seed": 1}
    again = params_from_state(copy.deepcopy(state["params"]), "ckpt.pth")
    assert again == dataclasses.replace(params, source="ckpt.pth")


def test_the_checkpointed_multi_agent_config_reads_back_equal():
    pytest.importorskip("pettingzoo")
    params = load_config(os.path.join(CONFIGS, "ppo_pz_simple_tag.yaml"))
    again = params_from_state(config_state(params)["params"], "ckpt.pth")
    assert again.policies.keys() == params.policies.keys()
    assert again == dataclasses.replace(params, source="ckpt.pth", policies={
        name: dataclasses.replace(p, source="ckpt.pth") for name, p in params.policies.items()})


def test_a_checkpointed_config_with_a_bad_value_is_a_config_error():
    state = config_state(parse())["params"]
    state["config"]["gamma"] = 2.0
    with pytest.raises(ConfigError, match=r"^ckpt.pth: params.config.gamma: must be between 0 and 1"):
        params_from_state(state, "ckpt.pth")
    with pytest.raises(ConfigError, match=r"^ckpt.pth: config: the checkpoint's config has no algo"):
        params_from_state({"config": {}}, "ckpt.pth")


# ----- import_modules: imported by the Runner, before parsing --------------------------------------
def test_the_parser_does_not_import_user_modules_the_runner_does(monkeypatch):
    imported = []
    module = types.ModuleType("i19c_user_pkg")
    monkeypatch.setitem(sys.modules, "i19c_user_pkg", module)
    real = __import__("importlib").import_module

    def spy(name, *args):
        imported.append(name)
        return real(name, *args)

    monkeypatch.setattr("importlib.import_module", spy)
    raw = copy.deepcopy(BASE)
    raw["params"]["import_modules"] = ["i19c_user_pkg"]
    assert parse_params(copy.deepcopy(raw), "cfg.yaml").import_modules == ["i19c_user_pkg"]
    assert "i19c_user_pkg" not in imported
    Runner().load(raw)
    assert "i19c_user_pkg" in imported


def test_a_module_that_cannot_be_imported_is_one_line():
    raw = copy.deepcopy(BASE)
    raw["params"]["import_modules"] = ["no_such_pkg_i19c"]
    with pytest.raises(ConfigError) as info:
        Runner().load(raw)
    assert str(info.value).startswith("<dict>: params.import_modules: cannot import 'no_such_pkg_i19c'")
    assert "\n" not in str(info.value)
    with pytest.raises(ConfigError, match=r"^cfg.yaml: params.import_modules: expected a list"):
        import_user_modules({"params": {"import_modules": "pkg"}}, "cfg.yaml")


# ----- network builders: config_class at registration, or a warning naming unknown keys -----------
@dataclasses.dataclass(frozen=True)
class TinyNetConfig:
    name: str = option("tiny_i19c", "registered network builder")
    hidden: int = option(8, "hidden units", check=lambda x: None if x > 0 else "must be > 0")


def test_register_network_with_a_config_class_checks_the_block():
    seen = []

    def tiny(params, **kwargs):
        seen.append(params)
        hidden = params["hidden"] if isinstance(params, dict) else params.hidden
        return nn.Linear(kwargs["input_shape"][0], hidden)

    model_builder.register_network("tiny_i19c", tiny, overwrite=True, config_class=TinyNetConfig)
    try:
        raw = copy.deepcopy(BASE)
        raw["params"]["network"] = {"name": "tiny_i19c", "hiden": 4}
        with pytest.raises(ConfigError, match=r"^cfg.yaml: params.network.hiden: unknown key; did you mean "
                                              r"'hidden'\?"):
            parse_params(raw, "cfg.yaml")
        raw["params"]["network"] = {"name": "tiny_i19c", "hidden": 4}
        params = parse_params(raw, "cfg.yaml")
        assert params.network == TinyNetConfig(hidden=4)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a typed block is never reported as unread
            assert instantiate(tiny, params.network, input_shape=(3,)).out_features == 4
        assert seen == [TinyNetConfig(hidden=4)]
    finally:
        model_builder.register_network("tiny_i19c", tiny, overwrite=True)  # and without: the dict again
    raw["params"]["network"] = {"name": "tiny_i19c", "hidden": 4, "hiden": 5}
    block = parse_params(raw, "cfg.yaml").network
    assert block == {"name": "tiny_i19c", "hidden": 4, "hiden": 5}
    with pytest.warns(UserWarning, match=r"^params.network: hiden not read by network builder 'tiny_i19c'"):
        instantiate(tiny, block, input_shape=(3,))


# ----- tune search files and torch_compile parse with the schema's fields -------------------------
def test_torch_compile_keys_are_checked_by_parse_value():
    from rlchain.config.compile import CompileSpec, parse_compile
    assert parse_compile({"backend": "eager"}) == CompileSpec("default", "default", "eager")
    assert parse_compile(CompileSpec("max-autotune")) == CompileSpec("max-autotune", "max-autotune")
    with pytest.raises(ValueError, match=r"^backend 'inductr' is not one of: inductor, .*\(did you mean 'inductor'"):
        parse_compile({"backend": "inductr"})


def test_search_file_scalars_parse_with_the_schema_fields(tmp_path):
    import yaml

    from rlchain.tuning.common import load_search
    base = os.path.join(CONFIGS, "ppo_cartpole.yaml")
    dist = {"params.config.gamma": {"type": "uniform", "low": 0.9, "high": 0.99}}
    path = tmp_path / "search.yaml"
    path.write_text(yaml.safe_dump({"base": base, "params": dist, "trials": "3", "verbose": "yes",
                                    "timeout": 60}))
    spec = load_search(str(path))
    assert spec.trials == 3 and spec.verbose is True and spec.timeout == 60.0
    path.write_text(yaml.safe_dump({"base": base, "params": dist, "direction": "maximise"}))
    with pytest.raises(ConfigError, match=r"search.yaml: direction: 'maximise' is not one of: maximize, minimize "
                                          r"\(did you mean 'maximize'\?\)"):
        load_search(str(path))
    path.write_text(yaml.safe_dump({"base": base, "params": dist, "overrides": ["params.config.gamma"]}))
    with pytest.raises(ConfigError, match=r"search.yaml: overrides: expected a list of 'key.path=value' strings"):
        load_search(str(path))


def test_ray_scheduler_blocks_parse_with_the_schema_fields(tmp_path):
    import yaml

    from rlchain.tuning.common import load_search
    base = os.path.join(CONFIGS, "ppo_cartpole.yaml")
    mutations = {"params.config.learning_rate": {"type": "loguniform", "low": 1e-5, "high": 1e-2}}
    path = tmp_path / "search.yaml"
    path.write_text(yaml.safe_dump({"base": base, "backend": "ray", "scheduler": "pbt",
                                    "pbt": {"interval_epochs": "4", "mutations": mutations}}))
    pbt = load_search(str(path)).ray.pbt
    assert pbt.interval_epochs == 4 and pbt.perturbation_factors == (1.2, 0.8)
    with pytest.raises(dataclasses.FrozenInstanceError):
        pbt.quantile = 0.5
    path.write_text(yaml.safe_dump({"base": base, "backend": "ray", "scheduler": "asha",
                                    "params": {"params.config.gamma": {"type": "uniform", "low": 0.9, "high": 0.99}},
                                    "asha": {"grace_epochs": 0}}))
    with pytest.raises(ConfigError, match=r"search.yaml: asha.grace_epochs: expected an integer >= 1, got 0$"):
        load_search(str(path))
