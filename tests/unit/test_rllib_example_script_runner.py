"""RLlib's example-script runner on the face (rlchain/rllib/examples/utils.py): how many ``train()`` calls a script's
flags and stop dict make, as RLlib 2.60's ``run_rllib_example_script_experiment`` makes them."""

import pytest

from rlchain.rllib.examples.utils import add_rllib_example_script_args, run_rllib_example_script_experiment


class _Algo:
    def __init__(self, returns):
        self.returns, self.calls, self.stopped = list(returns), 0, False

    @property
    def iteration(self):
        return self.calls

    def train(self):
        self.calls += 1
        return {"training_iteration": self.calls, "num_env_steps_sampled_lifetime": 100 * self.calls,
                "env_runners": {"episode_return_mean": self.returns[self.calls - 1]}}

    def stop(self):
        self.stopped = True


class _Config:
    algo_name = "PPO"

    def __init__(self, algo):
        self.algo = algo

    def build_algo(self):
        return self.algo

    def to_dict(self):
        return {}


@pytest.fixture(autouse=True)
def _tune_folder_in_tmp(tmp_path, monkeypatch):
    # without --no-tune the runner keeps Tune's experiment folder: here under the test's tmp_path
    monkeypatch.setattr("tempfile.mkdtemp", lambda prefix="": str(tmp_path / f"{prefix}experiment"))


def _run(flags, returns, stop=None):
    algo = _Algo(returns)
    args = add_rllib_example_script_args().parse_args(flags)
    run_rllib_example_script_experiment(_Config(algo), args, stop=stop, keep_config=True)
    return algo


def test_no_tune_caps_a_scripts_own_stop_dict_at_stop_iters():
    # multi_agent_cartpole_ppo.py passes stop={env steps, return} with no iteration count: RLlib's --no-tune loop
    # still runs --stop-iters iterations at most
    stop = {"num_env_steps_sampled_lifetime": 10**9, "env_runners/episode_return_mean": 450.0}
    algo = _run(["--no-tune", "--stop-iters=2"], [10.0] * 50, stop=stop)
    assert algo.calls == 2 and algo.stopped


def test_no_tune_takes_the_stop_dicts_own_iteration_count_first():
    algo = _run(["--no-tune", "--stop-iters=2"], [10.0] * 50, stop={"training_iteration": 4})
    assert algo.calls == 4


def test_without_no_tune_only_the_stop_dict_stops():
    # a Tune trial is stopped by the stop dict alone (here the return at the 5th iteration), not --stop-iters
    stop = {"env_runners/episode_return_mean": 450.0}
    algo = _run(["--stop-iters=2"], [10.0, 20.0, 30.0, 40.0, 460.0, 470.0], stop=stop)
    assert algo.calls == 5


@pytest.mark.parametrize("flags, calls", [(["--no-tune", "--stop-iters=3"], 3), (["--stop-iters=3"], 3)])
def test_the_default_stop_includes_stop_iters(flags, calls):
    algo = _run(flags, [10.0] * 50)
    assert algo.calls == calls


@pytest.mark.parametrize("flag, message", [
    ("--enable-new-api-stack", "`--enable-new-api-stack` flag no longer supported (it's the default behavior now)! "
                               "To switch back to the old API stack on your scripts, use the `--old-api-stack` flag."),
    ("--local-mode", "`--local-mode` is no longer supported.")])
def test_flags_rllib_no_longer_takes_are_its_value_error(flag, message, capsys):
    # RLlib 2.60 parses them (hidden from --help) and refuses them before training, with these words
    parser = add_rllib_example_script_args()
    parser.print_help()
    assert flag not in capsys.readouterr().out
    algo = _Algo([10.0])
    with pytest.raises(ValueError) as info:
        run_rllib_example_script_experiment(_Config(algo), parser.parse_args([flag, "--no-tune"]), keep_config=True)
    assert str(info.value) == message and algo.calls == 0


def test_as_release_test_is_as_test():
    with pytest.raises(ValueError, match="not reached"):
        _run(["--no-tune", "--stop-iters=1", "--stop-reward=50", "--as-release-test"], [10.0])


def test_an_iteration_before_the_first_episode_end_prints_without_a_return(capsys):
    # RLlib leaves env_runners/episode_return_mean out until an episode ended: the progress line says "-"
    algo = _Algo([None, 5.0])
    train = algo.train

    def without_return():
        result = train()
        if result["env_runners"]["episode_return_mean"] is None:
            del result["env_runners"]["episode_return_mean"]
        return result

    algo.train = without_return
    run_rllib_example_script_experiment(_Config(algo), add_rllib_example_script_args().parse_args(
        ["--no-tune", "--stop-iters=2"]), keep_config=True)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("iter 1: episode_return_mean -, env steps 100")
    assert lines[1].startswith("iter 2: episode_return_mean 5.00, env steps 200")
