"""PPO: rollout -> returns -> update, the on-policy Algorithm (rlchain.algos.base.algorithm) the Loop drives."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard, check_rollout
from rlchain.algos.core.collector import OnPolicyCollector
from rlchain.algos.core.returns import gae, next_values_from_rollout
from rlchain.algos.core.rnd import RandomNetworkDistillation, parts_to_indices
from rlchain.algos.core.storage import RolloutStorage, obs_buffer_layout, rollout_step_bytes
from rlchain.algos.core.symmetry import MirrorLoss, augmented_storage, resolve_mirror
from rlchain.algos.ppo.agent import PPOAgent, shuffled_minibatches
from rlchain.algos.ppo.central_value import CentralValueAgent
from rlchain.algos.ppo.distilled import load_distilled, warm_start_value
from rlchain.algos.ppo.env_layout import PipelineChoice, choose_env_layout, probed
from rlchain.algos.ppo.graph_step import GraphedAct, resolve_cuda_graph
from rlchain.algos.ppo.rllib_batch import rllib_bootstrap_advantages
from rlchain.config.actor_critic import check_batch
from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.config.ppo import PPOConfig
from rlchain.envs.factory import build_env
from rlchain.envs.spec import EnvSpec, env_spec
from rlchain.envs.vecenv import VecEnv
from rlchain.log import get_logger
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.build import build_central_value
from rlchain.models.compile import compile_model
from rlchain.parallel import communicator
from rlchain.parallel.memory import check_fits
from rlchain.runs import checkpoint as ckpt

log = get_logger(__name__)


class PPO(AlgorithmBase):
    """PPO (algos ``a2c_continuous`` and ``a2c_discrete``): rollout into a storage, then the PPO update
    (and the central value's, with an asymmetric critic)."""

    config_class = PPOConfig
    metric_tags = {"a_loss": "losses/a_loss", "c_loss": "losses/c_loss", "entropy": "losses/entropy",
                   "b_loss": "losses/bounds_loss", "lr": "info/last_lr", "lr_mul": "info/lr_mul", "kl": "info/kl",
                   "entropy_coef": "info/entropy_coef", "kl_coef": "info/kl_coef", "clip_frac": "info/clip_frac",
                   "grad_norm": "info/grad_norm",
                   "cval_loss": "losses/cval_loss", "cval_lr": "info/cval_lr", "rnd_loss": "losses/rnd_loss",
                   "rnd_reward": "rewards/intrinsic", "mirror_loss": "losses/mirror_loss"}
    console_fields = (("kl", "kl {:.4f}"), ("lr", "lr {:.2e}"))
    tunable = ("learning_rate", "entropy_coef", "e_clip", "critic_coef", "bounds_loss_coef", "grad_norm",
               "kl_threshold", "mini_epochs", "gamma", "tau")
    supports_distributed = True
    interruptible_update = True  # between minibatches, in a single process (see _stop_requested)
    self_play = True  # self_play_config: frozen opponents loaded into the env

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        """The minibatches (the actor's, the central value's) must divide the batch, which counts the env's agents
        (multi-agent envs); the rollout storage must fit the training device's free memory."""
        check_batch(params.config, params.source, spec.num_agents)
        cfg = params.config
        if spec.observation_space is not None and spec.action_space is not None:
            rows = cfg.horizon_length * spec.num_envs
            nbytes = rows * rollout_step_bytes(spec.observation_space, spec.action_space, spec.value_size)
            key = "params.config.horizon_length" if cfg.horizon_length >= cfg.num_actors else "params.config.num_actors"
            check_fits(nbytes, cfg.device, params.source, key, f"the rollout storage (horizon_length "
                       f"{cfg.horizon_length} x {spec.num_envs} env rows)")

    @classmethod
    def build_training_env(cls, params: Params, seed: int | None) -> Any:
        """The vectorized env, in ``env_groups`` that step in the background (the pipelined rollout); under
        ``env_groups: auto`` an envpool env is laid out as measured fastest (algos/ppo/env_layout.py)."""
        cfg = params.config
        env = build_env(params, cfg.num_actors, seed, runners=True, groups=cfg.env_groups)
        if not probed(env, params):
            return env
        try:
            return choose_env_layout(params, env, seed)
        except BaseException:
            env.close()
            raise

    def __init__(self, params: Params, env: VecEnv, model: ActorCritic, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        cfg, device = self.cfg, self.device
        compile_model(model, cfg.torch_compile)
        graphed = resolve_cuda_graph(cfg, model.a2c_network, model.is_rnn, device, ctx.comm.active, params.source)
        with communicator.building_with(ctx.comm):  # its normalizers fold every rank's batches
            self.central_value = build_central_value(params, env, device)
        self.cv_agent = None
        if self.central_value is not None:  # the asymmetric critic replaces the actor's value head
            self.cv_agent = CentralValueAgent(self.central_value, cfg.central_value_config, ctx.comm,
                                              should_stop=self._stop_requested)
        self.agent = PPOAgent(model, cfg, device, ctx.comm, cuda_graph=graphed,
                              train_critic=self.central_value is None, should_stop=self._stop_requested)
        if cfg.compile_update:
            _check_compile_update(model, params.source)
            self.agent.compile()
        obs_space = env.observation_space
        self.use_masks = _check_action_masks(cfg.use_action_masks, env, params.source)
        # RNN states carried through the rollout: the model's, then the central value's
        state_shapes = tuple(tuple(s.shape) for s in model.initial_state(self.num_envs, device))
        if self.central_value is not None:
            state_shapes += tuple(tuple(s.shape) for s in self.central_value.initial_state(self.num_envs, device))
        self.storage = RolloutStorage(
            cfg.horizon_length, self.num_envs, *obs_buffer_layout(obs_space),
            model.dist.action_shape, model.dist.action_dtype, model.dist.param_size,
            _value_size(env), device, mask_size=model.dist.param_size if self.use_masks else 0,
            state_shapes=state_shapes)
        self.divergence = DivergenceGuard(cfg.divergence, model, self.agent)
        # a fresh run starts from the distilled student; a resumed one holds its checkpoint's weights already
        fresh = cfg.distilled_checkpoint and not ctx.resuming
        self.distilled_teacher = load_distilled(params, env, model, device) if fresh else None
        # rsl_rl's extras: empirical normalization's timing, the RND intrinsic reward, the mirror loss
        self.fold_obs_each_step = obs_each_step(cfg.obs_normalizer_update, cfg.obs_normalizer)
        self.rnd = build_rnd(params, model, obs_space, device)
        self.mirror_loss = build_mirror_loss(params, model, obs_space, env.action_space)
        self._rnd_reward_sum, self._rnd_reward_rows = 0.0, 0
        # cuda_graph: the act step as a graph too, for a feed-forward policy without masks or central value
        plain = not model.is_rnn and not self.use_masks and self.central_value is None
        self.collector = OnPolicyCollector(
            env, model, ctx, cfg, storage=self.storage, central_value=self.central_value, use_masks=self.use_masks,
            pipeline_choice=PipelineChoice(auto=cfg.env_groups == "auto"),
            graphed_act=GraphedAct(model.act) if graphed and plain else None,
            reward_bonus=self.intrinsic_reward if self.rnd is not None else None,
            fold_obs_each_step=self.fold_obs_each_step, carries_states=True)

    # ----- the Algorithm hooks (rlchain.algos.base.algorithm) ------------------------------------
    def collect(self) -> bool:
        """A rollout of horizon_length steps into the storage (the collector); False when a stop signal came.
        A fresh run from a distilled student with ``distilled_value: teacher`` first regresses its value head."""
        if self.distilled_teacher is not None:
            if self.ctx.epoch == 0:
                mse = warm_start_value(self, self.distilled_teacher, self.cfg.distilled_value_epochs)
                log.info(f"value head regressed on the distilled teacher's values: mse {mse:.4g}")
            self.distilled_teacher = None  # once (a resumed run has its trained value head)
        return self.collector.rollout()

    def update(self) -> dict[str, float]:
        """GAE on the rollout, normalizer updates, the PPO update (PPOAgent.update: the minibatch loop and the
        loss), the extras' own updates (RND, mirror loss, central value).

        Every normalizer folds this rollout in before the update (the observations, with
        ``obs_normalizer_update: minibatch``, minibatch by minibatch in the update's first pass), so the
        network is trained with the statistics the next rollout acts with. (Folding the observations in
        after the update would train each update under one normalization and act under another, which
        slows learning per frame; docs/ppo_parity.md.)
        """
        cfg, storage, model = self.cfg, self.storage, self.model
        check_rollout(storage.rewards, storage.obs)
        flat_obs = storage.obs.reshape(-1, *storage.obs.shape[2:])
        with torch.no_grad():
            next_values = next_values_from_rollout(storage.values, self.collector.last_values,
                                                   storage.final_values, storage.dones)
            adv, returns = gae(storage.rewards, storage.values, next_values, storage.terminated,
                               storage.dones, cfg.gamma, cfg.tau)
            storage.advantages.copy_(adv)
            storage.returns.copy_(returns)
            bootstrap = None  # advantage_normalization rllib: RLlib's bootstrap rows' advantages join the stats
            if cfg.normalize_advantage and cfg.advantage_normalization == "rllib":
                bootstrap = rllib_bootstrap_advantages(storage, self.collector.last_values, cfg.gamma, cfg.tau)
            storage.final_values.zero_()
            flat_returns = returns.reshape(-1, returns.shape[-1])
            flat_values = storage.values.reshape(-1, storage.values.shape[-1])  # value_normalizer: rl_games
            each_step = self.fold_obs_each_step  # already folded in by the rollout (rsl_rl's timing)
            per_minibatch = not each_step and obs_per_minibatch(cfg.obs_normalizer_update, model.dist.continuous)
            model.update_normalizers(obs=None if per_minibatch or each_step else flat_obs, returns=flat_returns,
                                     values=flat_values)
            if self.central_value is not None:
                self.central_value.update_normalizers(obs=None if each_step else flat_obs, returns=flat_returns,
                                                      values=flat_values)
        model.train()
        symmetry = cfg.symmetry
        if symmetry is not None and symmetry.data_augmentation:  # the PPO update sees the mirror images too
            if per_minibatch:  # the statistics stay the env's: fold the original rows in once, here
                with torch.no_grad():
                    model.update_normalizers(obs=flat_obs)
            stats = self.agent.update(augmented_storage(storage, self.mirror_loss.mirror, model.obs_slice),
                                      self.progress())
        else:
            stats = self.agent.update(storage, self.progress(), obs_per_minibatch=per_minibatch,
                                      bootstrap_advantages=bootstrap)
        stats["lr0"] = cfg.learning_rate
        stats["lr_mul"] = stats["lr"] / max(cfg.learning_rate, 1e-12)
        if self.rnd is not None:  # the predictor learns the rollout's states: their intrinsic reward fades
            stats.update(self.train_rnd(flat_obs))
        if self.mirror_loss is not None and self.mirror_loss.coef > 0:  # symmetry: the policy acts as its mirror
            stats["mirror_loss"] = self.mirror_loss.train_on(flat_obs, cfg.minibatch_size)
        if self.cv_agent is not None:
            stats.update(self.cv_agent.update(storage, self.progress(), model.num_states, cfg.seq_length,
                                              cfg.zero_rnn_on_done,
                                              shuffled_minibatches(cfg.minibatch_order, model.dist.continuous)))
        return stats

    def _stop_requested(self) -> bool:
        """A stop signal came (checked between minibatches). Under torchrun the update always finishes: the
        ranks would leave it at different minibatches and wait for each other in the gradient all-reduce."""
        signals = self.ctx.signals
        return signals is not None and signals.by_signal and not self.ctx.comm.active

    def learners(self) -> list[tuple[torch.nn.Module, Any]]:
        """The actor-critic and PPO agent, and the central value with its own agent when there is one."""
        pairs = [(self.model, self.agent)]
        if self.central_value is not None:
            pairs.append((self.central_value, self.cv_agent))
        return pairs

    def intrinsic_reward(self, obs: Any) -> torch.Tensor:
        """``rnd``: the (B, 1) intrinsic rewards of a step's next observations (their statistics folded in
        first, as rsl_rl does)."""
        view = self.model.view(self.ctx.to_tensor(obs))
        self.rnd.observe(view)
        reward = self.rnd.reward(view)
        self._rnd_reward_sum += float(reward.sum())
        self._rnd_reward_rows += reward.numel()
        return reward.unsqueeze(-1)

    def train_rnd(self, flat_obs: torch.Tensor) -> dict[str, float]:
        """The predictor's passes over the rollout; its loss and the epoch's mean intrinsic reward."""
        rnd_cfg = self.cfg.rnd
        loss = self.rnd.train_on(self.model.view(flat_obs), self.cfg.minibatch_size, rnd_cfg.mini_epochs)
        mean = self._rnd_reward_sum / max(self._rnd_reward_rows, 1)
        self._rnd_reward_sum, self._rnd_reward_rows = 0.0, 0
        return {"rnd_loss": loss, "rnd_reward": mean}

    def extra_state(self, kind: str) -> dict:
        """The central value's weights and optimizer, when there is one; the RND's."""
        out = {} if self.rnd is None else {"rnd": self.rnd.full_state()}
        if self.mirror_loss is not None:
            out["mirror_optimizer"] = self.mirror_loss.optimizer.state_dict()
        if self.central_value is None:
            return out
        return {**out, "central_value": self.central_value.state_dict(),
                "central_value_agent": self.cv_agent.state_dict()}

    def restore_extra(self, state: dict) -> None:
        if self.rnd is not None and "rnd" in state:
            self.rnd.load_full_state(state["rnd"])
        if self.mirror_loss is not None and "mirror_optimizer" in state:
            self.mirror_loss.optimizer.load_state_dict(state["mirror_optimizer"])
        if self.central_value is None:
            return
        if "central_value" not in state:
            raise ckpt.CheckpointError("checkpoint has no central value network; it was trained without "
                                       "central_value_config")
        self.central_value.load_state_dict(state["central_value"])
        self.cv_agent.load_state_dict(state["central_value_agent"])

    # ----- bookkeeping ----------------------------------------------------------------------
    def frames_per_epoch(self) -> int:
        """Env steps per epoch over all ranks, as rl_games counts them: agents of one env share a step."""
        ctx = self.ctx
        return self.cfg.horizon_length * (self.num_envs // ctx.num_agents) * ctx.world_size


def _check_action_masks(use_action_masks: bool, env: VecEnv, source: str) -> bool:
    """With use_action_masks the env must provide masks; a one-line ConfigError otherwise."""
    if not use_action_masks:
        return False
    if not env_spec(env).action_masks:
        raise ConfigError(source, "params.config.use_action_masks",
                          "True, but the env has no action masks (has_action_mask() / get_action_mask())")
    return True


def _check_compile_update(model: ActorCritic, source: str) -> None:
    """compile_update compiles a feed-forward minibatch step; a one-line ConfigError otherwise."""
    if model.is_rnn:
        raise ConfigError(source, "params.config.compile_update",
                          "False for an RNN network (sequence minibatches are not compiled); set it false")
    if callable(getattr(model.a2c_network, "get_aux_loss", None)):
        raise ConfigError(source, "params.config.compile_update",
                          "False for a network with get_aux_loss() (its losses are checked in Python)")


def _value_size(env: VecEnv) -> int:
    return env_spec(env).value_size


def build_rnd(params: Params, model: ActorCritic, obs_space: Any, device: torch.device) -> Any:
    """The ``rnd`` block's networks on the actor's view of the observation (None without the block)."""
    cfg = params.config.rnd
    if cfg is None:
        return None
    size = int(model.view(torch.zeros((1, *obs_space.shape))).flatten(1).shape[1])
    try:
        indices = parts_to_indices(cfg.obs, size)
    except ValueError as exc:
        raise ConfigError(params.source, "params.config.rnd.obs", str(exc)) from None
    return RandomNetworkDistillation(size, cfg, indices, device)


def build_mirror_loss(params: Params, model: ActorCritic, obs_space: Any, action_space: Any) -> Any:
    """The ``symmetry`` block's mirror loss on the actor's view (None without the block)."""
    cfg = params.config.symmetry
    if cfg is None:
        return None
    if not model.dist.continuous or model.is_rnn:
        raise ConfigError(params.source, "params.config.symmetry", "needs a feed-forward policy with continuous "
                                                                   "actions")
    size = int(model.view(torch.zeros((1, *obs_space.shape))).flatten(1).shape[1])
    try:
        mirror = resolve_mirror(cfg.mirror, size, int(np.prod(action_space.shape)))
    except ValueError as exc:
        raise ConfigError(params.source, "params.config.symmetry.mirror", str(exc)) from None
    return MirrorLoss(model, mirror, cfg.mirror_loss_coef, params.config.learning_rate)


def obs_each_step(mode: str, kind: str) -> bool:
    """``obs_normalizer_update`` resolved: True when the rollout folds each env step's next observations into
    the observation statistics (step, or auto with ``obs_normalizer: rsl_rl``, rsl_rl's timing)."""
    return mode == "step" or (mode == "auto" and kind == "rsl_rl")


def obs_per_minibatch(mode: str, continuous: bool) -> bool:
    """``obs_normalizer_update`` resolved: True when each minibatch of the update's first pass folds its
    observations in (minibatch, or auto with continuous actions), False for the whole rollout at once."""
    return mode == "minibatch" or (mode == "auto" and continuous)
