"""``params.config`` of ``algo: distill`` (:class:`DistillConfig`): a frozen teacher (an rlchain PPO
checkpoint) labels the states a student visits, DAgger-style; see docs/distillation.md."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rlchain.config.fields import non_negative, option, positive, unit_interval
from rlchain.config.obs_groups import ObsGroupsConfig
from rlchain.config.run import RunConfig


@dataclass(frozen=True)
class DistillConfig(RunConfig):
    """``params.config`` of ``algo: distill``: the student (``params.network``) learns to act like the teacher."""

    # words for its heading in docs/config.md
    doc_note: ClassVar[str] = ("a frozen PPO teacher labels the states a student visits, DAgger; "
                               "docs/distillation.md; keys shared with PPO have the same meaning")

    teacher_checkpoint: str = option("", "the teacher: an rlchain PPO checkpoint (a2c_continuous / a2c_discrete) "
                                         "or SAC one (labels with its deterministic action; loss mse or huber), "
                                         "frozen; its network and input statistics come from the checkpoint. "
                                         "Read as --checkpoint is: a path, nn/<x>.pth or a packaged name (cartpole)")
    obs_groups: ObsGroupsConfig | None = option(None, "the teacher's and the student's views (default: the "
                                                      "teacher's = what it was trained on, the student's = all)")
    horizon_length: int = option(32, "steps per env per epoch", check=positive)
    learning_rate: float = option(1e-3, "Adam learning rate of the student", check=positive)
    weight_decay: float = option(0.0, "Adam weight decay", check=non_negative)
    mini_epochs: int = option(2, "passes over each rollout", check=positive)
    minibatches: int = option(2, "minibatches per pass, split by env (an RNN student trains on whole "
                                     "rollouts of its envs); must divide num_actors", check=positive)
    dataset_epochs: int = option(1, "DAgger's aggregated dataset: each update trains on the labelled rollouts "
                                    "of the last this many epochs (1 = the current rollout only)",
                                 check=positive)
    loss: str = option("auto", "behaviour loss: mse or huber on the action means (continuous), kl = "
                               "KL(teacher || student) on the action distributions, cross_entropy = the "
                               "student's negative log-likelihood of the teacher's action; auto = mse for "
                               "continuous actions, kl otherwise",
                       choices=("auto", "mse", "huber", "kl", "cross_entropy"))
    huber_delta: float = option(1.0, "huber: where the loss turns from quadratic to linear", check=positive)
    teacher_action_prob: float = option(1.0, "DAgger's beta at the start: the probability that the teacher, "
                                             "not the student, acts (per episode or per step: mixing)",
                                        check=unit_interval)
    teacher_action_prob_end: float = option(0.0, "beta at the end of the schedule", check=unit_interval)
    teacher_action_prob_epochs: int = option(10, "epochs over which beta moves linearly from "
                                                 "teacher_action_prob to teacher_action_prob_end",
                                             check=non_negative)
    mixing: str = option("episode", "who acts is drawn with beta once per episode (each episode wholly the "
                                    "teacher's or the student's: both returns are logged) or every step",
                         choices=("episode", "step"))
    student_deterministic: bool = option(True, "the student acts with its distribution's mode (else samples)")
    bptt_length: int | None = option(None, "RNN student: backpropagate through at most this many steps "
                                           "(truncated BPTT over the rollout; default: the whole horizon)",
                                     check=positive)
    use_action_masks: bool = option(False, "invalid-action masks from the env (discrete and multi-discrete), "
                                           "applied to the student's and the teacher's distributions")
    normalize_value: bool = option(False, "the student's value normalizer (its value head is not trained "
                                          "here): set it as the stage-three PPO config has it, so that "
                                          "distilled_checkpoint loads")
    value_normalizer: str = option("rl_games", "which value statistics the student's normalizer keeps (as PPO's "
                                               "key: set it as the stage-three PPO config has it)",
                                   choices=("rl_games", "returns"))
    truncate_grads: bool = option(True, "clip gradients to grad_norm")
    grad_norm: float = option(1.0, "max gradient norm", check=positive)

    @property
    def model_group(self) -> str:
        """The model the loop trains and checkpoints is the student: it reads the student's group."""
        return "student"

    def validate(self) -> tuple[str, str] | None:
        """Cross-key checks: a teacher is required, the minibatches split the envs."""
        if not self.teacher_checkpoint:
            return "teacher_checkpoint", "required: the path of the teacher's PPO or SAC checkpoint"
        if self.num_actors % self.minibatches:
            return "minibatches", f"{self.minibatches} does not divide num_actors {self.num_actors}"
        return None
