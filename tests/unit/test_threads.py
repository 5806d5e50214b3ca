"""rlchain.parallel.threads: thread counts per training phase, and the params.update_threads key."""

import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params
from rlchain.envs.backends.torch_envs.cartpole import TorchCartPole
from rlchain.parallel import threads as threads_module
from rlchain.parallel.threads import ThreadPlan, for_env, free_cores, idle_cores, plan_threads

BASE = {"params": {"algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
                   "network": {"name": "actor_critic", "mlp": {"units": [8]}},
                   "config": {"env_name": "CartPole-v1", "num_actors": 2, "horizon_length": 4,
                              "minibatch_size": 8}}}


def test_default_is_half_the_cores_for_the_rollout_and_all_of_them_for_the_update():
    assert plan_threads(None, None, "cpu", cores=8, load=0.0) == ThreadPlan(4, 4)
    assert plan_threads(None, None, "cpu", cores=4, load=0.0) == ThreadPlan(2, 4)
    assert plan_threads(None, None, "cpu", cores=2, load=0.9) == ThreadPlan(1, 2)
    assert plan_threads(None, None, "cpu", cores=1, load=0.0) == ThreadPlan(1, 1)
    assert plan_threads(None, None, "cpu", cores=32, load=0.0) == ThreadPlan(4, 4)
    assert plan_threads(None, None, "cpu", processes=2, cores=4, load=0.0) == ThreadPlan(1, 2)


def test_default_update_leaves_out_the_cores_other_processes_keep_busy():
    def now(plan):
        return plan.current()

    assert now(plan_threads(None, None, "cpu", cores=2, load=1.2)) == (1, 1)
    assert plan_threads(None, None, "cpu", cores=2, load=1.2) == ThreadPlan(1, 2)  # 2 once the cores are idle
    assert now(plan_threads(None, None, "cpu", cores=2, load=7.0)) == (1, 1)
    assert now(plan_threads(None, None, "cpu", cores=8, load=5.5)) == (4, 4)  # never below the rollout's
    assert now(plan_threads(None, None, "cpu", cores=16, load=13.0)) == (4, 4)
    assert now(plan_threads(None, None, "cpu", cores=4, load=3.0)) == (2, 2)
    assert plan_threads(None, 2, "cpu", cores=2, load=7.0) == ThreadPlan(1, 2)  # asked for: kept
    assert idle_cores(4, 2.7) == 2 and idle_cores(2, 9.0) == 1 and idle_cores(2, 0.0) == 2


def test_free_cores_counts_a_core_busy_from_a_third_of_one():
    assert free_cores(2, 0.0) == 2 and free_cores(2, 0.25) == 2
    assert free_cores(2, 0.35) == 1 and free_cores(2, 1.0) == 1 and free_cores(2, 5.0) == 1
    assert free_cores(8, 2.5) == 5


def _fake_stat(tmp_path, busy, idle):
    path = tmp_path / "stat"
    path.write_text(f"cpu  {busy} 0 0 {idle} 0 0 0 0 0 0\n")
    return str(path)


def test_other_load_is_the_machine_busy_time_less_this_process(tmp_path, monkeypatch):
    clock = {"t": 100.0, "cpu": 5.0}
    monkeypatch.setattr(threads_module.time, "monotonic", lambda: clock["t"])
    monkeypatch.setattr(threads_module.time, "process_time", lambda: clock["cpu"])
    load = threads_module.OtherLoad(_fake_stat(tmp_path, 0, 0))
    tick = load.tick
    # one wall second: the machine busy 1.5 cores' worth, this process 0.5 s of it -> others 1.0 core
    load.stat = _fake_stat(tmp_path, int(1.5 * tick), 10)
    clock["t"], clock["cpu"] = 101.0, 5.5
    assert load.since_last() == pytest.approx(1.0)
    clock["t"] += 0.001  # under 20 ms: no estimate
    assert load.since_last() is None


def test_an_adaptive_update_drops_to_one_thread_while_others_are_busy_and_comes_back(monkeypatch):
    before = torch.get_num_threads()
    seen = []
    others = iter([0.0, 1.0, 0.0, 0.0, 0.0, 0.0])  # rollout, update, rollout, update, ...
    plan = ThreadPlan(1, 2, adaptive=True, cores=2)
    monkeypatch.setattr(threads_module.OtherLoad, "since_last", lambda self: next(others))
    try:
        plan.apply()
        for _ in range(3):
            with plan.update_phase():
                seen.append(torch.get_num_threads())
        # the first update knows nothing yet (2); the second follows the first, which others kept busy
        # (1); the third follows an idle one (2); the rollout stays at its 1 throughout
        assert seen == [2, 1, 2] and torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


def test_an_asked_update_count_is_kept_even_under_load(monkeypatch):
    before = torch.get_num_threads()
    plan = ThreadPlan(1, 2, adaptive=True, fixed_update=True, cores=2)
    monkeypatch.setattr(threads_module.OtherLoad, "since_last", lambda self: 1.5)
    try:
        plan.apply()
        for _ in range(2):
            with plan.update_phase():
                assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_an_explicit_torch_threads_also_caps_the_update_unless_update_threads_is_set():
    assert plan_threads(1, None, "cpu", cores=2) == ThreadPlan(1, 1)
    assert plan_threads(2, None, "cpu", cores=8) == ThreadPlan(2, 2)
    assert plan_threads(1, 2, "cpu", cores=2) == ThreadPlan(1, 2)


def test_requests_are_capped_at_the_process_share_of_cores():
    assert plan_threads(3, 8, "cpu", cores=4) == ThreadPlan(3, 4)
    assert plan_threads(None, 2, "cpu", cores=2) == ThreadPlan(1, 2)
    assert plan_threads(4, 4, "cpu", processes=2, cores=4) == ThreadPlan(2, 2)


def test_cuda_keeps_torch_choice_unless_asked():
    assert plan_threads(None, None, "cuda:0", cores=8) is None
    assert plan_threads(2, None, "cuda:0", cores=8) == ThreadPlan(2, 2)


def test_update_phase_switches_and_restores():
    before = torch.get_num_threads()
    try:
        plan = ThreadPlan(1, 2)
        plan.apply()
        with plan.update_phase():
            assert torch.get_num_threads() == 2
        assert torch.get_num_threads() == 1
        with pytest.raises(RuntimeError), plan.update_phase():
            raise RuntimeError("update failed")
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


def test_update_threads_key_parses_and_rejects_bad_values():
    raw = {"params": {**BASE["params"], "update_threads": 2}}
    assert parse_params(raw, "cfg.yaml").update_threads == 2
    for bad in (0, "two"):
        with pytest.raises(ConfigError, match=r"cfg\.yaml.*params\.update_threads"):
            parse_params({"params": {**BASE["params"], "update_threads": bad}}, "cfg.yaml")



def test_busy_cores_reads_the_cpu_time_other_processes_use_now(tmp_path, monkeypatch):
    """Non-idle share of /proc/stat's cpu time over the window, times the cores: here 200 of 300
    ticks busy on 2 cores -> 1.33 cores, so 1 idle core is left for the update."""
    import rlchain.parallel.threads as threads

    stat = tmp_path / "stat"
    stat.write_text("cpu  100 0 100 800 0 0 0 0 0 0\ncpu0 ...\n")

    def sleep(seconds):  # the window passes: 100 user, 100 system and 100 idle ticks later
        stat.write_text("cpu  200 0 200 900 0 0 0 0 0 0\n")

    monkeypatch.setattr(threads.time, "sleep", sleep)
    monkeypatch.setattr(threads.os, "cpu_count", lambda: 2)
    assert threads.busy_cores(stat=str(stat)) == pytest.approx(4 / 3)
    assert threads.busy_cores(stat=str(tmp_path / "missing")) is None


def test_idle_cores_uses_the_cpu_busy_now_not_the_one_minute_average(monkeypatch):
    """Right after another run ended the 1-minute load average is still ~2.7 on an idle 2-core
    machine; the update must still get both cores."""
    import rlchain.parallel.threads as threads

    monkeypatch.setattr(threads.os, "getloadavg", lambda: (2.7, 2.0, 1.0))
    monkeypatch.setattr(threads, "SAMPLE_MAX_AGE", 0.0)  # sample afresh each call
    monkeypatch.setattr(threads, "busy_cores", lambda: 0.1)
    assert idle_cores(2) == 2
    monkeypatch.setattr(threads, "busy_cores", lambda: 1.6)  # another process holds a core
    assert idle_cores(2) == 1
    monkeypatch.setattr(threads, "busy_cores", lambda: None)  # no /proc/stat: the load average
    assert idle_cores(2) == 1


def test_runs_started_back_to_back_in_one_process_share_one_core_sample(monkeypatch):
    """The 0.2 s sample is taken once per SAMPLE_MAX_AGE seconds in a process, then taken afresh."""
    import rlchain.parallel.threads as threads

    samples = []
    clock = [100.0]
    monkeypatch.setattr(threads, "_last_sample", None)
    monkeypatch.setattr(threads.time, "monotonic", lambda: clock[0])
    monkeypatch.setattr(threads, "busy_cores", lambda: samples.append(clock[0]) or 1.5)
    assert idle_cores(2) == 1 and idle_cores(4) == 3
    assert samples == [100.0]
    clock[0] += threads.SAMPLE_MAX_AGE + 0.1
    assert idle_cores(2) == 1
    assert samples == [100.0, 100.0 + threads.SAMPLE_MAX_AGE + 0.1]


def test_playing_plans_no_update_threads_and_samples_no_cores(monkeypatch):
    """--play never runs a gradient update: the rollout's count, without the 0.2 s /proc/stat sample."""
    import rlchain.parallel.threads as threads

    def no_sample(*args, **kwargs):
        raise AssertionError("busy_cores sampled for a play")

    monkeypatch.setattr(threads, "busy_cores", no_sample)
    assert plan_threads(None, None, "cpu", cores=2, updates=False) == ThreadPlan(1, 1)
    assert plan_threads(2, None, "cpu", cores=8, updates=False) == ThreadPlan(2, 2)


def test_a_tensor_env_rollout_takes_the_update_count_and_other_envs_keep_theirs():
    class Envpool:  # its own threads step the envs: the rollout leaves them the other cores
        pass

    before = torch.get_num_threads()
    try:
        tensor_env = TorchCartPole(4)
        plan = plan_threads(None, None, "cpu", cores=2, load=0.0)
        adjusted = for_env(plan, tensor_env, None)
        assert adjusted == ThreadPlan(2, 2) and torch.get_num_threads() == 2  # applied now
        assert for_env(plan, Envpool(), None) is plan
        assert for_env(plan_threads(1, None, "cpu", cores=2, load=0.0), tensor_env, 1) == ThreadPlan(1, 1)
        assert for_env(None, tensor_env, None) is None  # CUDA: torch's own choice
        busy = for_env(plan_threads(None, None, "cpu", cores=2, load=1.2), tensor_env, None)
        assert busy.current() == (1, 1)  # the machine was busy at the start: both phases start at one
    finally:
        torch.set_num_threads(before)
