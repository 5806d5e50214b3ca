"""Joining Ray for the env runners (:mod:`rlchain.envs.ray.ray_env`): start a local one or reach a cluster.

``ray.init(address=...)`` keeps retrying for many minutes when nobody answers at the address, so
the address is checked first with a plain TCP connect: an unreachable cluster is a one-line
error within seconds instead of a hang.
"""

from __future__ import annotations

import math
import os
import socket
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.run import EnvRunnersConfig

ADDRESS = "params.config.env_runners.address"


def connect(ray: Any, runners: EnvRunnersConfig, workers: int) -> bool:
    """``ray.init`` unless this process is connected already; True when this call started a local Ray.

    ``env_runners.address`` (else the ``RAY_ADDRESS`` environment variable, as Ray reads it) names
    a cluster to join; without either a local Ray is started with enough CPUs for ``workers``.
    """
    if ray.is_initialized():
        return False
    address = runners.address or os.environ.get("RAY_ADDRESS") or None
    kwargs: dict[str, Any] = {"runtime_env": runners.runtime_env or None}
    if address is None:
        cpus = max(os.cpu_count() or 1, math.ceil(workers * runners.num_cpus_per_worker))
        kwargs.update(num_cpus=cpus, include_dashboard=False)
    else:
        check_reachable(address, min(10.0, runners.start_timeout_s))
        kwargs["address"] = address
    try:
        ray.init(**kwargs)
    except Exception as exc:
        where = f"cannot connect to Ray at '{address}'" if address else "cannot start Ray"
        raise ConfigError("", ADDRESS, f"{where}: {one_line(exc)}") from None
    return address is None


def check_reachable(address: str, seconds: float) -> None:
    """A ConfigError unless something accepts a TCP connection at the cluster's ``host:port``."""
    target = address
    if address == "auto":
        try:
            from ray._private.services import canonicalize_bootstrap_address
            target = canonicalize_bootstrap_address("auto")
        except ConnectionError as exc:
            raise ConfigError("", ADDRESS, f"'auto' found no running Ray cluster: {one_line(exc, typed=False)}") \
                from None
        except Exception:  # Ray's private helper moved: let ray.init find it
            return
        if target is None:
            return
    host, _, port = target.removeprefix("ray://").rpartition(":")
    try:
        socket.create_connection((host or "127.0.0.1", int(port)), timeout=seconds).close()
    except (OSError, ValueError) as exc:
        raise ConfigError("", ADDRESS, f"cannot reach Ray at '{address}' ({host}:{port}): "
                                       f"{exc.strerror or exc}; is the cluster up (ray start --head)?") from None


def one_line(exc: BaseException, typed: bool = True) -> str:
    """``Type: first line of the message`` (Ray errors carry whole tracebacks); ``typed=False``: the line."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    text = lines[0] if lines else ""
    text = text if len(text) <= 300 else text[:297] + "..."
    return f"{type(exc).__name__}: {text}" if typed and text else text or type(exc).__name__


def task_failed(exc: Any, what: str, where: str) -> BaseException:
    """The one-line error for an exception an env raised inside a Ray call (``RayTaskError``): a config
    error (ValueError) at start stays a ValueError; anything else is a RuntimeError naming ``where``."""
    cause = getattr(exc, "cause", None) or exc
    if isinstance(cause, ValueError) and what == "start":
        return ValueError(one_line(cause, typed=False))
    return RuntimeError(f"{where}: {one_line(cause)}")


def kill(ray: Any, worker: Any) -> None:
    """Kill one actor for good; one already dead, or a Ray already gone, is fine."""
    try:
        ray.kill(worker, no_restart=True)
    except Exception:
        pass


def release(ray: Any, workers: list[Any], owns_ray: bool) -> None:
    """Kill every actor, and shut down the local Ray when this process started it."""
    for worker in workers:
        kill(ray, worker)
    if owns_ray and ray.is_initialized():
        ray.shutdown()
