"""Ray Tune search (``backend: ray``): PBT exploits through live set_params and beats its starting
config, a crashed trial restarts from its checkpoint, ASHA and FIFO run. One Ray session for all.

Each search is as small as what it shows: two trials, one at a time where the order matters (FIFO's crash, ASHA's
rung) and side by side only for PBT, which compares running trials (tests/smoke/tune_pace.py makes them meet).
What a trial costs is mostly its actor's start (a process importing torch and rlchain), not its epochs."""

import glob
import json
import math
import os
import statistics

import pytest
import yaml

from rlchain.config import load_config
from rlchain.runner import Runner
from rlchain.tuning import ray_search
from rlchain.tuning.common import load_search
from tests.conftest import CONFIGS, installed
from tests.smoke import ray_session

# marks, not pytest.importorskip("ray.tune"): that imports Ray Tune (pandas, pyarrow: about 2 s of CPU) when the
# file is collected, in every pytest process; pandas and pyarrow stand for rlchain[ray]'s Tune part (looking
# ray.tune up would import ray)
pytestmark = installed("ray", "pandas", "pyarrow")

BASE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
EPOCHS = 30
START_LR = 2e-5  # barely learns in 30 epochs: the starting config every trial of FIFO and PBT begins with
# games_to_track 32: the mean reward follows the policy of the last ~2 epochs (PBT compares trials by it)
FIXED = ["params.config.lr_schedule=None", "params.config.save_best_after=1000", "params.config.games_to_track=32"]
# tune_pace.Pace: the 2 concurrent trials of PBT start together and stay in step (PBT compares them)
PACE = "params.config.callbacks=[tests.smoke.tune_pace:Pace]"
CPUS = 2  # the test cluster: two trials of one CPU at once


@pytest.fixture(scope="module")
def ray_cluster():
    handlers = ray_search._signal_handlers()  # Ray installs its own; later tests get theirs back
    with ray_session.session(CPUS):
        yield
    ray_search._restore_signal_handlers(handlers)


def _fit(tmp_path, name, **keys):
    search = {"base": BASE, "backend": "ray", "metric": "mean_reward", "trials": 2, "concurrent": 1,
              "max_epochs_per_trial": EPOCHS, "overrides": FIXED, "seed": 0, **keys}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(search))
    return ray_search.fit(load_search(str(path)), output=str(tmp_path / name / "best.yaml"),
                          train_dir=str(tmp_path / name / "runs"))


def _final(outcome):
    return [r.metrics["mean_reward"] for r in outcome.results if "mean_reward" in (r.metrics or {})]


@pytest.fixture(scope="module")
def start_runs(ray_cluster, tmp_path_factory):
    """FIFO: the starting config, 2 seeds one after the other (the fifo smoke test and PBT's yardstick); the
    first trial crashes once at epoch 5 (tests/smoke/tune_crash.py) and must resume from its epoch-3 checkpoint.
    Its cost is two trial actors' starts (the crashed one's and the restarted one's, which the second trial
    reuses) and 60 CartPole epochs."""
    tmp = tmp_path_factory.mktemp("fifo")
    return tmp, _fit(tmp, "fifo", scheduler="fifo", searcher="optuna", checkpoint_epochs=3, max_failures=1,
                     overrides=FIXED + ["params.config.callbacks=[tests.smoke.tune_crash:CrashOnce]"],
                     params={"params.config.learning_rate": {"type": "categorical", "choices": [START_LR]}})


def test_fifo_runs_every_trial_to_the_end(start_runs):
    _, outcome = start_runs
    assert len(outcome.results) == 2 and not outcome.results.errors
    assert all(r.metrics["training_iteration"] == EPOCHS for r in outcome.results)
    assert len(set(_final(outcome))) > 1  # distinct seeds per trial
    assert load_config(outcome.config_path).config.learning_rate == pytest.approx(START_LR)


def test_crashed_trial_restarts_from_its_checkpoint(start_runs):
    from tests.smoke.tune_crash import CRASH_AT

    tmp, outcome = start_runs
    assert len(glob.glob(str(tmp / "fifo" / "runs" / "*" / "crashed_once"))) == 1  # one trial crashed ...
    restored = []
    for result in outcome.results:
        frame = result.metrics_dataframe
        restored += frame[frame["restored_epoch"] >= 0]["restored_epoch"].tolist()
    assert restored == [3] and 3 < CRASH_AT  # ... and resumed from its epoch-3 checkpoint, not from scratch


def test_pbt_exploits_live_and_beats_its_starting_config(ray_cluster, start_runs, tmp_path):
    """Two trials side by side, both from the starting config: at every interval the worse one takes the
    better one's checkpoint and a fresh lr from a range that learns; the best ends well above FIFO's runs of the
    starting config. A PBT that never exploits, or whose new values do not go live, stays at the start's lr."""
    outcome = _fit(tmp_path, "pbt", scheduler="pbt", concurrent=2, overrides=FIXED + [PACE],
                   params={"params.config.learning_rate": {"type": "categorical", "choices": [START_LR]}},
                   # every exploit resamples the lr from a range that learns within the trial's 30 epochs
                   pbt={"interval_epochs": 3, "quantile": 0.5, "resample_probability": 1.0,
                        "perturbation_factors": [2.0, 0.5],
                        "mutations": {"params.config.learning_rate":
                                      {"type": "loguniform", "low": 1e-3, "high": 1e-2},
                                      "params.config.entropy_coef": {"type": "uniform", "low": 0.0, "high": 0.01}}})
    assert not outcome.results.errors
    # an exploit: a trial resumed from another's checkpoint with perturbed values ...
    assert outcome.exploits, "no PBT exploit happened"
    exploit = outcome.exploits[0]
    assert exploit["from"] != exploit["trial"] and exploit["before"] != exploit["after"]
    # ... and the perturbed values went live through set_params (get_params reports them)
    for result in outcome.results:
        frame = result.metrics_dataframe
        rows = frame[frame["exploited_from"].fillna("").astype(str) != ""]
        for _, row in rows.iterrows():
            after = json.loads(row["exploit"])["after"]
            assert row["hp/learning_rate"] == pytest.approx(after["params.config.learning_rate"], rel=1e-5)
            assert row["hp/entropy_coef"] == pytest.approx(after["params.config.entropy_coef"], rel=1e-5)
    best = max(_final(outcome))
    median = statistics.median(_final(start_runs[1]))
    lrs = {r.metrics["trial_id"]: r.metrics_dataframe["hp/learning_rate"].round(6).tolist() for r in outcome.results}
    assert best > median + 20, (best, median, _final(outcome), lrs)
    # the winner's schedule: a config that replays it
    params = load_config(outcome.schedule_path)
    schedule = params.config.hyperparam_schedule
    assert 0 in schedule and schedule[0]["learning_rate"] == pytest.approx(START_LR)
    replay = Runner().load(outcome.schedule_path, ["params.config.max_epochs=2", "params.config.print_stats=false",
                                                   f"params.config.train_dir={tmp_path / 'replay'}"]).train()
    assert replay.epoch == 2
    assert math.isfinite(outcome.best_value)


def test_asha_stops_bad_trials_early(ray_cluster, tmp_path):
    # one trial at a time, in grid order: lr 1e-2 (mean reward ~37 at epoch 10) runs to the end; lr 1e-5 (~21)
    # then reaches the epoch-10 rung below it and ASHA stops it there (reduction factor 3: the top third goes on)
    outcome = _fit(tmp_path, "asha", scheduler="asha", searcher="grid", trials=1, max_epochs_per_trial=14,
                   asha={"grace_epochs": 10, "reduction_factor": 3},
                   params={"params.config.learning_rate": {"type": "categorical", "choices": [1e-2, 1e-5]}})
    iterations = {r.config["params.config.learning_rate"]: r.metrics["training_iteration"] for r in outcome.results}
    assert not outcome.results.errors and iterations == {1e-2: 14, 1e-5: 10}  # ASHA stopped the bad one at the rung
    assert os.path.isfile(outcome.config_path) and os.path.isfile(outcome.table_path)


def _trial(tmp_path, name):
    """A new actor with a trial's trainable (tests/smoke/tune_trial.py), as a (re)started trial gets one."""
    from rlchain.config.load import load_raw
    from rlchain.tuning.trainable import TrialSetup
    from tests.smoke.tune_trial import Trial

    overrides = ["params.network.mlp.units=[16]", "params.config.num_actors=4", "params.config.minibatch_size=32",
                 "params.config.max_epochs=6", "params.config.print_stats=false", "params.torch_threads=1",
                 "params.update_threads=1", f"params.config.train_dir={tmp_path / name}"]
    setup = TrialSetup(base=load_raw(BASE), overrides=overrides, keys=[], seed=0)
    return Trial.remote(setup, str(tmp_path / "ray_logdirs"))


def test_a_restarted_trial_continues_bit_identically(ray_cluster, tmp_path):
    """Exact resume in a Ray Tune trial: a trial restored from its epoch-3 checkpoint in a new actor (what a
    max_failures restart does: a new actor, ``load_checkpoint``, then ``step``) reports epochs 4-6 exactly as
    a trial that never stopped and ends with identical parameters, optimizer state and episodes (torch.equal).
    Tune's own scheduling around it (FailureConfig) is test_crashed_trial_restarts_from_its_checkpoint's.

    The trial that never stopped writes the epoch-3 checkpoint on its way (as a Tune trial checkpoints every
    checkpoint_epochs and goes on), so two actors show it: that one, and the restarted one, started beside it
    (its process imports torch and rlchain while the first trains) and killed after."""
    import ray

    from rlchain.runs import checkpoint as ckpt
    from tests.smoke.test_exact_resume import assert_same

    def kept(result):
        return {k: v for k, v in result.items() if k not in ("fps", "epoch_seconds", "restored_epoch")}

    def steps(actor, epochs):
        return [ray.get(actor.step.remote()) for _ in range(epochs)]

    def end(actor, save):
        ray.get(actor.save.remote(str(tmp_path / save)))
        ray.get(actor.stop.remote())
        ray.kill(actor)  # the trial's actor dies; its CPU goes back to the session

    straight_actor, restarted_actor = _trial(tmp_path, "straight"), _trial(tmp_path, "restarted")
    straight = steps(straight_actor, 3)
    ray.get(straight_actor.save.remote(str(tmp_path / "ck3")))
    straight = [kept(r) for r in straight + steps(straight_actor, 3)]
    end(straight_actor, "ck_straight")
    ray.get(restarted_actor.load.remote(str(tmp_path / "ck3")))
    resumed = steps(restarted_actor, 3)
    end(restarted_actor, "ck_restarted")
    assert resumed[0]["restored_epoch"] == 3 and [kept(r) for r in resumed] == straight[3:]
    s, r = (ckpt.load(str(tmp_path / d / "rlchain.pth")) for d in ("ck_straight", "ck_restarted"))
    assert s["epoch"] == r["epoch"] == 6
    for key in ("model", "agent", "episodes"):
        assert_same(s[key], r[key], key)
    assert_same(s["run_state"]["running"], r["run_state"]["running"], "episodes in progress")
