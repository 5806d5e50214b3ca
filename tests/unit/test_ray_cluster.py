"""The Ray helpers both Ray runner kinds share (rlchain.envs.ray.ray_cluster), without Ray: fakes stand in."""

from __future__ import annotations

import pytest

from rlchain.envs.ray.ray_cluster import kill, release, task_failed


class TaskError(Exception):
    """Like Ray's RayTaskError: a long message, the env's own exception as ``cause``."""

    def __init__(self, cause: BaseException) -> None:
        super().__init__(f"ray traceback line\n{cause}\nmore traceback")
        self.cause = cause


@pytest.mark.parametrize("what, cause, kind, text", [
    ("start", ValueError("env_name: 'Nope' is not registered\ndetails"), ValueError,
     "env_name: 'Nope' is not registered"),
    ("step", ValueError("bad action"), RuntimeError, "ray env worker 1 (envs 2-3) step: ValueError: bad action"),
    ("start", KeyError("x"), RuntimeError, "ray env worker 1 (envs 2-3) start: KeyError: 'x'"),
])
def test_task_failed_keeps_config_errors_and_names_the_worker_otherwise(what, cause, kind, text):
    error = task_failed(TaskError(cause), what, f"ray env worker 1 (envs 2-3) {what}")
    assert type(error) is kind and str(error) == text


def test_task_failed_without_a_cause_reports_the_error_itself():
    error = task_failed(RuntimeError("boom\ntraceback"), "sample", "appo ray runner 0 (envs 0-3) sample")
    assert str(error) == "appo ray runner 0 (envs 0-3) sample: RuntimeError: boom"


class FakeRay:
    def __init__(self, dead: set[str], initialized: bool = True) -> None:
        self.dead, self.killed, self.initialized, self.shut_down = dead, [], initialized, False

    def kill(self, worker: str, no_restart: bool) -> None:
        assert no_restart
        if worker in self.dead:
            raise ValueError(f"{worker} is dead already")
        self.killed.append(worker)

    def is_initialized(self) -> bool:
        return self.initialized

    def shutdown(self) -> None:
        self.shut_down = True


def test_kill_passes_over_a_dead_actor():
    ray = FakeRay(dead={"a"})
    kill(ray, "a")
    kill(ray, "b")
    assert ray.killed == ["b"]


@pytest.mark.parametrize("owns, initialized, shut_down", [(True, True, True), (False, True, False),
                                                          (True, False, False)])
def test_release_kills_every_actor_and_shuts_down_only_its_own_ray(owns, initialized, shut_down):
    ray = FakeRay(dead={"b"}, initialized=initialized)
    release(ray, ["a", "b", "c"], owns)
    assert ray.killed == ["a", "c"] and ray.shut_down is shut_down
