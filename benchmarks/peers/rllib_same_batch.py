"""One PPO update of RLlib 2.60 and of rlchain's face on the same batch from the same weights (RLlib's tuned CartPole
settings, ``cartpole_ppo.py``): advantages, value targets, loss terms, KL, the new ``kl_coeff`` and the weights
after, side by side.

    python benchmarks/peers/rllib_same_batch.py --rllib-python /work/peers/rllib/bin/python --out /tmp/same_batch

The RLlib side (``--side rllib``, the side venv's Python with ``ray[rllib]==2.60.0``; no Ray cluster: the learner
is built with ``config.build_learner``) draws the initial weights and a batch (2 env columns x 2,000 CartPole
steps, actions sampled from the initial policy; CartPole's time limit lowered to 25 steps so the batch holds
truncations as well as terminations, and each column ends mid-episode as an env runner's chunk does) and saves
both as data (``batch.npz``); it then feeds the batch to RLlib's own learner as episodes, one column after the
other (what 2 env runners of 1 env each hand it), through its learner connector pipeline and ``update()``. The
face's side (``--side face``, this environment, ``python -m rlchain.rllib``) loads the same weights into the
face's network, writes the batch into the face's rollout storage and runs the face's PPO update. Each side saves
what it computed (``<side>.npz``); the driver prints the largest differences.

Variants: ``whole`` (1 epoch, one minibatch of the whole batch), ``whole2`` (2 epochs of the whole batch: the KL
and the adapted ``kl_coeff`` are nonzero; no minibatch order to match), ``minibatch`` (each side's real
minibatching, 6 epochs: RLlib's ``MiniBatchCyclicIterator`` of 128 rows over its batch, the masked bootstrap rows
included; the face's ``minibatch_order: rllib`` over the same rows, replaying the permutations RLlib drew at its
wraps, recorded on RLlib's side, so both take the same rows in the same order). The face standardizes its
advantages with RLlib's bootstrap rows (``advantage_normalization: rllib``). ``--face-option KEY=VALUE`` sets a
``params.config`` key of the face's translated config (e.g. ``minibatch_order='"shuffle"'`` or
``advantage_normalization='"batch"'`` to try the face without one of its RLlib switches).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

ENVS, STEPS, TIME_LIMIT = 2, 2000, 25
VARIANTS = {"whole": (1, None), "whole2": (2, None), "minibatch": (6, 128)}  # (epochs, RLlib's minibatch_size)
# RLlib's module parameter -> the face's (vf_share_layers=True: one linear layer of 32 shared by both heads)
NAMES = {"encoder.encoder.net.mlp.0.weight": "a2c_network.actor_mlp.0.weight",
         "encoder.encoder.net.mlp.0.bias": "a2c_network.actor_mlp.0.bias",
         "pi.net.mlp.0.weight": "a2c_network.logits.weight", "pi.net.mlp.0.bias": "a2c_network.logits.bias",
         "vf.net.mlp.0.weight": "a2c_network.value.weight", "vf.net.mlp.0.bias": "a2c_network.value.bias"}
FED = ("whole2",)  # variants the face also runs on RLlib's advantages and value targets (``<name>+rllib_adv``)
STATS = ("policy_loss", "vf_loss", "entropy", "mean_kl_loss", "curr_kl_coeff")


def _config(seed: int, epochs: int = 6, minibatch: int | None = 128):
    from rllib_cartpole import tuned_cartpole_config

    config = tuned_cartpole_config(seed, 2)
    return config.training(num_epochs=epochs, minibatch_size=minibatch or ENVS * STEPS)


# ----- RLlib's side ---------------------------------------------------------------------------------------------
def _rllib_learner(seed: int, epochs: int, minibatch: int | None, weights: dict | None):
    import gymnasium as gym
    import torch

    torch.manual_seed(seed)
    env = gym.make("CartPole-v1")
    learner = _config(seed, epochs, minibatch).build_learner(env=env)
    module = learner.module["default_policy"]
    if weights is not None:
        state = module.state_dict()
        state.update({k: torch.as_tensor(v) for k, v in weights.items()})
        module.load_state_dict(state)
    return learner, module


def _make_batch(module, seed: int) -> dict[str, np.ndarray]:
    """2 columns x STEPS CartPole steps from the module's policy; each column's episodes back to back."""
    import gymnasium as gym
    import torch

    rng = np.random.default_rng(seed)
    envs = [gym.make("CartPole-v1", max_episode_steps=TIME_LIMIT) for _ in range(ENVS)]
    obs = np.zeros((ENVS, STEPS, 4), np.float32)
    final = np.zeros((ENVS, STEPS, 4), np.float32)  # the observation after the step (the final one at a done)
    logits = np.zeros((ENVS, STEPS, 2), np.float32)
    out = {k: np.zeros((ENVS, STEPS), t) for k, t in (("actions", np.int64), ("logp", np.float32),
                                                      ("rewards", np.float32), ("terminated", bool),
                                                      ("truncated", bool))}
    for e, env in enumerate(envs):
        o, _ = env.reset(seed=seed * 100 + e)
        for t in range(STEPS):
            with torch.no_grad():
                lg = module.forward_exploration({"obs": torch.as_tensor(o[None], dtype=torch.float32)})
            lg = lg["action_dist_inputs"][0].numpy().astype(np.float32)
            logp = lg - np.log(np.exp(lg - lg.max()).sum()) - lg.max()
            a = int(rng.choice(2, p=np.exp(logp) / np.exp(logp).sum()))
            nxt, r, term, trunc, _ = env.step(a)
            obs[e, t], logits[e, t], final[e, t] = o, lg, nxt
            out["actions"][e, t], out["logp"][e, t], out["rewards"][e, t] = a, logp[a], r
            out["terminated"][e, t], out["truncated"][e, t] = term, trunc and not term
            o = env.reset()[0] if term or trunc else nxt
    return {"obs": obs, "next_obs": final, "logits": logits, **out}


def _episodes(batch: dict[str, np.ndarray]):
    """The batch as RLlib's SingleAgentEpisodes: column 0's episodes in time order, then column 1's (2 env runners
    of one env each); the last chunk of a column is unfinished (RLlib's sampler hands it over mid-episode)."""
    import gymnasium as gym
    from ray.rllib.env.single_agent_episode import SingleAgentEpisode

    obs_space = gym.make("CartPole-v1").observation_space
    episodes = []
    for e in range(ENVS):
        start = 0
        done = batch["terminated"][e] | batch["truncated"][e]
        ends = [t + 1 for t in np.flatnonzero(done)] + ([STEPS] if not done[-1] else [])
        for end in ends:
            sl = slice(start, end)
            observations = [*batch["obs"][e, sl], batch["next_obs"][e, end - 1]]
            episodes.append(SingleAgentEpisode(
                observations=observations, observation_space=obs_space, action_space=gym.spaces.Discrete(2),
                actions=list(batch["actions"][e, sl]), rewards=list(batch["rewards"][e, sl]),
                terminated=bool(batch["terminated"][e, end - 1]), truncated=bool(batch["truncated"][e, end - 1]),
                extra_model_outputs={"action_logp": list(batch["logp"][e, sl]),
                                     "action_dist_inputs": list(batch["logits"][e, sl])},
                len_lookback_buffer=0).to_numpy())
            start = end
    return episodes


def _flat(results: dict) -> dict[str, float]:
    """RLlib's update results (possibly Stats objects) -> {name: float} of the default module's."""
    mine = results.get("default_policy", {})
    out = {}
    for key in STATS:
        value = mine.get(key)
        value = value.peek() if hasattr(value, "peek") else value
        out[key] = float(np.asarray(value).mean()) if value is not None else float("nan")
    return out


def rllib_side(out: str, seed: int) -> None:
    import copy

    import torch

    _, module = _rllib_learner(seed, 1, None, None)
    weights = {k: v.detach().numpy().copy() for k, v in module.state_dict().items() if k in NAMES}
    batch = _make_batch(module, seed)
    np.savez(os.path.join(out, "batch.npz"), **batch, **{f"w:{k}": v for k, v in weights.items()})
    episodes = _episodes(batch)
    saved = {}
    for name, (epochs, minibatch) in VARIANTS.items():
        learner, module = _rllib_learner(seed, epochs, minibatch, weights)
        # the learner connector's batch (advantages, value targets, the loss mask), on copies of the episodes
        conn = learner._learner_connector(rl_module=learner.module, batch={}, episodes=copy.deepcopy(episodes),
                                          shared_data={}, metrics=learner.metrics)["default_policy"]
        mask = np.asarray(conn["loss_mask"], bool)
        adv, targets = np.asarray(conn["advantages"]), np.asarray(conn["value_targets"])
        with torch.no_grad():
            values = module.compute_values({"obs": torch.as_tensor(np.asarray(conn["obs"]))}).numpy()
        perms, permutation = [], np.random.permutation

        # SampleBatch.shuffle's draw at each wrap of RLlib's cyclic minibatches, recorded
        def recorded(n, perms=perms, permutation=permutation):
            out = permutation(n)
            perms.append(np.asarray(out))
            return out

        np.random.permutation = recorded
        try:
            results = learner.update(episodes=copy.deepcopy(episodes), num_epochs=epochs, minibatch_size=minibatch,
                                     shuffle_batch_per_epoch=True,
                                     timesteps={"num_env_steps_sampled_lifetime": 4000})
        finally:
            np.random.permutation = permutation
        saved[f"{name}:perms"] = np.stack(perms) if perms else np.zeros((0, mask.size), np.int64)
        stats = _flat(results if isinstance(results, dict) else results[0])
        saved.update({f"{name}:adv": adv[mask], f"{name}:targets": targets[mask], f"{name}:values": values[mask],
                      f"{name}:raw_adv": (targets - values), f"{name}:mask": mask,
                      f"{name}:stats": np.array([stats[k] for k in STATS])})
        saved.update({f"{name}:w:{k}": v.detach().numpy() for k, v in module.state_dict().items() if k in NAMES})
    np.savez(os.path.join(out, "rllib.npz"), **saved)


# ----- the face's side ------------------------------------------------------------------------------------------
def face_side(out: str, seed: int, options: dict) -> None:
    import dataclasses

    import torch

    from rlchain.algos.ppo import rllib_batch

    data = np.load(os.path.join(out, "batch.npz"))
    saved = {}
    permutation = rllib_batch.torch_permutation
    for name, (epochs, minibatch) in [*VARIANTS.items(), *((f"{k}+rllib_adv", VARIANTS[k]) for k in FED)]:
        algo = _config(seed, epochs, minibatch).build_algo()
        ppo = algo._stepper.context.algorithm  # parked before its first rollout
        if options:
            ppo.cfg = dataclasses.replace(ppo.cfg, **options)
            ppo.agent.cfg = ppo.cfg
        model, storage = ppo.model, ppo.storage
        state = model.state_dict()
        for k, face_k in NAMES.items():
            state[face_k] = torch.as_tensor(data[f"w:{k}"])
        model.load_state_dict(state)
        tn = lambda x: torch.as_tensor(np.swapaxes(x, 0, 1).copy())  # (N, T, ...) -> (T, N, ...)
        obs = tn(data["obs"])
        with torch.no_grad():
            values = model.value(obs.reshape(-1, 4)).reshape(STEPS, ENVS, 1)
            final = model.value(tn(data["next_obs"]).reshape(-1, 4)).reshape(STEPS, ENVS, 1)
        storage.obs.copy_(obs)
        storage.actions.copy_(tn(data["actions"]).to(storage.actions.dtype).reshape(storage.actions.shape))
        storage.log_probs.copy_(tn(data["logp"]))
        storage.params.copy_(tn(data["logits"]))
        storage.values.copy_(values)
        storage.rewards.copy_(tn(data["rewards"]).unsqueeze(-1))
        term, trunc = tn(data["terminated"]), tn(data["truncated"])
        storage.terminated.copy_(term)
        storage.dones.copy_(term | trunc)
        # V(final obs) at every done (GAE reads it at time-outs only; RLlib's bootstrap rows at terminations too)
        storage.final_values.copy_(torch.where((term | trunc).unsqueeze(-1), final, torch.zeros_like(final)))
        storage.filled = STEPS
        ppo.collector.last_values = final[-1]  # the observation after each column's last step
        rllib = np.load(os.path.join(out, "rllib.npz"))
        base = name.split("+")[0]
        if ppo.cfg.minibatch_order == "rllib":
            rows = len(rllib_batch.batch_rows((term | trunc).numpy()))
            if minibatch is None:  # RLlib's whole batch is every row of it, its bootstrap rows too
                ppo.cfg = ppo.agent.cfg = dataclasses.replace(ppo.cfg, minibatch_size=rows)
            # RLlib's own shuffles, replayed in the face's cyclic order (RLlib's 1-epoch whole batch has none:
            # its dummy iterator; the face's cyclic one wraps once at the end, which changes nothing there)
            perms, draws = iter(rllib[f"{base}:perms"]), []
            rllib_batch.torch_permutation = lambda n, perms=perms, draws=draws: draws.append(n) or next(
                perms, np.arange(n))
            saved[f"{name}:draws"] = draws
        if name.endswith("+rllib_adv"):  # RLlib's advantages and value targets, the face's update
            back = lambda x: torch.as_tensor(x.reshape(ENVS, STEPS).T.copy())  # env-major rows -> (T, N)
            ppo.cfg = ppo.agent.cfg = dataclasses.replace(ppo.cfg, normalize_advantage=False)
            storage.advantages.copy_(back(rllib[f"{base}:adv"]).unsqueeze(-1))
            storage.returns.copy_(back(rllib[f"{base}:targets"]).unsqueeze(-1))
            stats = ppo.agent.update(storage, 0.0)
        else:
            stats = ppo.update()
        adv = ppo.agent._batch_advantages(storage)  # what the update trained on
        flat = lambda x: x.transpose(0, 1).reshape(-1).numpy()  # env-major, as RLlib's rows
        saved.update({f"{name}:adv": flat(adv), f"{name}:targets": flat(storage.returns.sum(-1)),
                      f"{name}:values": flat(values.sum(-1)),
                      f"{name}:stats": np.array([stats["a_loss"], stats["c_loss"], stats["entropy"], stats["kl"],
                                                 stats.get("kl_coef", float("nan"))])})
        weights = model.state_dict()
        saved.update({f"{name}:w:{k}": weights[face_k].numpy() for k, face_k in NAMES.items()})
        algo.stop()
        rllib_batch.torch_permutation = permutation
        saved[f"{name}:draws"] = np.array(len(saved.get(f"{name}:draws", [])))
    np.savez(os.path.join(out, "face.npz"), **saved)


# ----- the comparison -------------------------------------------------------------------------------------------
def compare(out: str) -> list[str]:
    r, f = np.load(os.path.join(out, "rllib.npz")), np.load(os.path.join(out, "face.npz"))
    b = np.load(os.path.join(out, "batch.npz"))
    w0 = {k: b[f"w:{k}"] for k in NAMES}
    lines = [f"batch: {ENVS} x {STEPS} steps, {int(b['terminated'].sum())} terminations, "
             f"{int(b['truncated'].sum())} truncations (time limit {TIME_LIMIT})"]
    for name in VARIANTS:
        mask = r[f"{name}:mask"]
        raw = r[f"{name}:raw_adv"]
        lines.append(f"-- {name} (epochs {VARIANTS[name][0]}, RLlib minibatch {VARIANTS[name][1] or 'whole batch'};"
                     f" RLlib's batch {mask.size} rows, {int((~mask).sum())} of them its masked bootstrap rows)")
        for key in ("values", "targets", "adv"):
            d = np.abs(r[f"{name}:{key}"] - f[f"{name}:{key}"])
            scale = np.abs(r[f"{name}:{key}"]).mean()
            lines.append(f"   {key:8s} max |RLlib - face| {d.max():.3g} (mean |RLlib| {scale:.3g})")
        # RLlib standardizes over every row of its batch, the masked bootstrap rows too
        real_only = (raw[mask] - raw[mask].mean()) / max(1e-4, raw[mask].std())
        lines.append(f"   RLlib's advantages standardized over the real rows only (rlchain's batch) vs RLlib's: max "
                     f"diff {np.abs(real_only - r[f'{name}:adv']).max():.3g}; raw advantage of the masked rows: "
                     f"mean {raw[~mask].mean():.3g}, real rows {raw[mask].mean():.3g} (std {raw[mask].std():.3g}, "
                     f"all rows {raw.std():.3g})")
        lines.append(f"   RLlib's minibatch shuffles: {len(r[f'{name}:perms'])}, the face's cyclic order drew "
                     f"{int(f[f'{name}:draws'])} (RLlib's replayed)")
        rs, fs = r[f"{name}:stats"], f[f"{name}:stats"]
        lines.append("   " + ", ".join(f"{k} {a:.6g} / {c:.6g}" for k, a, c in zip(STATS, rs, fs)) + "  (RLlib / face)")
        for k in NAMES:
            step_r = r[f"{name}:w:{k}"] - w0[k]
            d = np.abs(r[f"{name}:w:{k}"] - f[f"{name}:w:{k}"]).max()
            lines.append(f"   {k:34s} after: max |RLlib - face| {d:.3g} (RLlib's step max {np.abs(step_r).max():.3g})")
    for name in FED:
        fed = f"{name}+rllib_adv"
        rs, fs = r[f"{name}:stats"], f[f"{fed}:stats"]
        lines.append(f"-- {fed}: the face's update on RLlib's advantages and value targets, against RLlib's {name}")
        lines.append("   " + ", ".join(f"{k} {a:.6g} / {c:.6g}" for k, a, c in zip(STATS, rs, fs)) + "  (RLlib / face)")
        worst = max(np.abs(r[f"{name}:w:{k}"] - f[f"{fed}:w:{k}"]).max() for k in NAMES)
        step = max(np.abs(r[f"{name}:w:{k}"] - w0[k]).max() for k in NAMES)
        lines.append(f"   weights after: max |RLlib - face| {worst:.3g} over all layers (RLlib's step max {step:.3g})")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", choices=("rllib", "face"), help="run one side (the driver runs both)")
    parser.add_argument("--rllib-python", default="/work/peers/rllib/bin/python")
    parser.add_argument("--out", default="rllib_same_batch", help="folder for the .npz files (outside git)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--face-option", action="append", default=[], help="KEY=VALUE (JSON value)")
    parser.add_argument("--compare-only", action="store_true", help="compare the .npz files already in --out")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.face_option)}
    if args.side == "rllib":
        rllib_side(args.out, args.seed)
        return
    if args.side == "face":
        face_side(args.out, args.seed, options)
        return
    if not args.compare_only:
        root = os.path.dirname(os.path.dirname(HERE))
        here = os.path.abspath(__file__)
        common = [here, "--out", args.out, "--seed", str(args.seed), *sum((["--face-option", o]
                                                                           for o in args.face_option), [])]
        env_rllib = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        subprocess.run([args.rllib_python, *common, "--side", "rllib"], env=env_rllib, check=True)
        subprocess.run([sys.executable, "-m", "rlchain.rllib", *common, "--side", "face"],
                       env={**os.environ, "PYTHONPATH": root, "OMP_NUM_THREADS": "1"}, check=True)
    print("\n".join(compare(args.out)))


if __name__ == "__main__":
    main()
