"""A trained policy as a thing: stepping it (:mod:`~rlchain.policy.stepper`) and playing it on an env
(:mod:`~rlchain.policy.play`, the one loop evaluation, the Player, video and export share).

It sits below ``training/`` and ``inference/`` (both use it) and above ``models/`` and ``envs/``.
"""
