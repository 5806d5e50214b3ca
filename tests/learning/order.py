"""The order the learning tier runs in under ``pytest -n N --dist worksteal``: the longest tests first on every worker.

pytest-xdist's worksteal scheduler hands worker k the k-th contiguous share of the collected tests (the shares differ
by at most one test) and, when a worker runs out, moves the second half of the busiest worker's queue to it. In
collection order (alphabetical files) the long tests sit wherever their file's name puts them, and the tier ends
with one worker still running a long test that started late while the other idles. Here the tests are dealt to the
shares longest first, each to the share with the least work so far (the longest-processing-time rule), each share
longest first: both workers start on a long test, and what a finished worker steals from the tail of another's queue
is its shortest tests.

``SECONDS`` holds each slow test's CPU seconds on one torch thread (``RLCHAIN_TEST_TIMES`` of one process's run of
the tier on the 2-core Intel Xeon at load 11-40, 2026-11-29; docs/layout.md's learning table); only their order
matters, so refresh it when a test's cost changes by much. A test not in it counts 0 and runs last, in collection
order. tests/tools/worksteal_order.py replays the scheduler on measured times to compare orders.
"""

from __future__ import annotations

from collections.abc import Sequence

SECONDS: dict[str, float] = {
    "tests/learning/test_history_learning.py::test_history_policy_reaches_450_on_masked_velocity_cartpole": 99,
    "tests/learning/test_pettingzoo_learning.py::test_simple_tag_predators_trained_with_the_prey_beat_their_starting_selves":
        93,
    "tests/learning/test_learning.py::test_ppo_brax_inverted_pendulum_reaches_900": 84,
    "tests/learning/test_learning.py::test_ppo_playground_cartpole_balance_reaches_800": 84,
    "tests/learning/test_distill_learning.py::test_halfcheetah_student_without_velocities_reaches_90_percent_of_the_teacher":
        81,
    "tests/learning/test_sb3_learning.py::test_ppo_cartpole_with_sb3s_defaults_learns_as_sb3": 80,
    "tests/learning/test_learning.py::test_ppo_halfcheetah_improves": 69,
    "tests/learning/test_pettingzoo_learning.py::test_simple_tag_prey_trained_alone_beats_its_starting_self_and_the_predators_stay":
        58,
    "tests/learning/test_distill_learning.py::test_lstm_student_reaches_90_percent_of_the_mlp_teacher": 55,
    "tests/learning/test_off_policy_learning.py::test_sac_pendulum_reaches_minus_250_within_20k_steps": 52,
    "tests/learning/test_sb3_learning.py::test_sac_pendulum_learns": 43,
    "tests/learning/test_rnn_learning.py::test_lstm_reaches_450_on_masked_velocity_cartpole": 43,
    "tests/learning/test_pettingzoo_learning.py::test_connect_four_self_play_beats_a_random_player_90_percent": 37,
    "tests/learning/test_rllib_learning.py::test_rllibs_tuned_cartpole_settings_learn_within_rllibs_budget": 36,
    "tests/learning/test_pettingzoo_learning.py::test_simple_spread_shared_policy_beats_random_play": 33,
    "tests/learning/test_mujoco_push_learning.py::test_push_cube_learns_to_push": 32,
    "tests/learning/test_off_policy_learning.py::test_dqn_cartpole_reaches_200": 32,
    "tests/learning/test_camera_reach_learning.py::test_multi_input_policy_reaches_0_6_success": 28,
    "tests/learning/test_metaworld_learning.py::test_ppo_metaworld_reach_success_rate": 27,
    "tests/learning/test_appo_learning.py::test_appo_pendulum_learns_to_minus_400": 25,
    "tests/learning/test_rnn_env_learning.py::test_rnn_remembers_the_goal": 22,
    "tests/smoke/test_rllib_learners.py::test_two_learners_train_data_parallel_under_torchrun": 21,
    "tests/learning/test_rnn_env_learning.py::test_feedforward_cannot": 20,
    "tests/learning/test_learning.py::test_ppo_pendulum_reaches_minus_250": 19,
    "tests/learning/test_rllib_multi_agent_learning.py::test_a_users_module_learns_cartpole": 18,
    "tests/learning/test_rllib_multi_agent_learning.py::test_two_policies_learn_a_multi_agent_env": 15,
    "tests/learning/test_appo_learning.py::test_appo_cartpole_reaches_475": 15,
    "tests/learning/test_distill_learning.py::test_student_of_a_sac_teacher_reaches_pendulum_score": 14,
    "tests/learning/test_her_learning.py::test_sac_her_fetch_reach_success_rate": 13,
    "tests/smoke/test_rllib_algorithms.py::test_env_runners_are_rays_after_ray_init": 13,
    "tests/learning/test_rnn_learning.py::test_feedforward_cannot_solve_masked_velocity_cartpole": 13,
    "tests/smoke/test_rllib_face.py::test_tuner_runs_ppo_by_name_on_real_ray_tune": 12,
    "tests/learning/test_apg_learning.py::test_apg_pendulum_improves_past_minus_400": 11,
    "tests/learning/test_self_play.py::test_self_play_beats_random_and_heuristic": 10,
    "tests/learning/test_camera_reach_learning.py::test_vector_only_policy_stays_at_chance": 10,
    "tests/learning/test_sb3_learning.py::test_ppo_cartpole_50k_reaches_475": 9,
    "tests/learning/test_apg_learning.py::test_apg_point_mass_reaches_success_0_9": 8,
    "tests/learning/test_multi_agent_learning.py::test_cooperative_agents_learn_to_meet": 8,
    "tests/smoke/test_tensor_env_training.py::test_torch_cartpole_reaches_475_and_plays_gymnasium_cartpole": 7,
    "tests/learning/test_learning.py::test_ppo_cartpole_reaches_475": 7,
    "tests/learning/test_rsl_rl_extras_learning.py::test_torch_pendulum_reaches_its_score_with_each_extra[symmetry_augmentation]":
        6,
    "tests/learning/test_rsl_rl_extras_learning.py::test_torch_pendulum_reaches_its_score_with_each_extra[rnd]": 5,
    "tests/learning/test_masked_learning.py::test_without_masks_the_same_config_fails": 5,
    "tests/learning/test_rsl_rl_extras_learning.py::test_torch_pendulum_reaches_its_score_with_each_extra[obs_normalizer]":
        5,
    "tests/learning/test_learning.py::test_shipped_checkpoints_play_to_score[ppo_cartpole.yaml-cartpole.pth-475]": 5,
    "tests/learning/test_grpo_learning.py::test_grpo_learns[grpo_point_mass.yaml-<lambda>-False]": 4,
    "tests/learning/test_rsl_rl_extras_learning.py::test_torch_pendulum_reaches_its_score_with_each_extra[symmetry]": 4,
    "tests/learning/test_grpo_learning.py::test_grpo_learns[grpo_point_mass.yaml-<lambda>-True]": 4,
    "tests/learning/test_learning.py::test_shipped_checkpoints_play_to_score[ppo_pendulum.yaml-pendulum.pth--250]": 3,
    "tests/learning/test_grpo_learning.py::test_grpo_learns[grpo_torch_cartpole.yaml-<lambda>-True]": 2,
    "tests/learning/test_grpo_learning.py::test_grpo_learns[grpo_torch_cartpole.yaml-<lambda>-False]": 2,
    "tests/learning/test_multidiscrete_learning.py::test_multidiscrete_reaches_098": 2,
    "tests/learning/test_masked_learning.py::test_masked_policy_reaches_085_and_plays_within_masks[multidiscrete_4_3]":
        2,
    "tests/learning/test_masked_learning.py::test_masked_policy_reaches_085_and_plays_within_masks[discrete_6]": 1,
}


def share_sizes(count: int, workers: int) -> list[int]:
    """How many of ``count`` tests worksteal's first hand-out gives each of ``workers`` (xdist 3.x: each worker in
    turn gets the pending tests divided by the workers still to serve, rounded down)."""
    sizes, left = [], count
    for k in range(workers):
        sizes.append(left // (workers - k))
        left -= sizes[-1]
    return sizes


def seconds_of(nodeid: str) -> float:
    """A test's seconds in ``SECONDS``: its own node id, else its function's (all its parameters), else 0."""
    return SECONDS.get(nodeid, SECONDS.get(nodeid.split("[")[0], 0.0))


def longest_first(seconds: Sequence[float], workers: int) -> list[int]:
    """Indices of tests taking ``seconds`` in the order that gives each of ``workers`` worksteal shares of about equal
    work, each share longest first. Ties (the unmeasured tests: 0) keep their order."""
    by_length = sorted(range(len(seconds)), key=lambda i: -seconds[i])  # stable
    sizes = share_sizes(len(seconds), workers)
    shares: list[list[int]] = [[] for _ in sizes]
    work = [0.0] * workers
    for i in by_length:
        # the share with room and the least work so far (the first such on a tie)
        k = min((k for k in range(workers) if len(shares[k]) < sizes[k]), key=lambda k: work[k])
        shares[k].append(i)
        work[k] += seconds[i]
    return [i for share in shares for i in share]
