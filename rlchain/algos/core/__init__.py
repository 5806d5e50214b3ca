"""Pure math and storage shared by the algorithms: returns, losses, schedules, rollout storage, replay, V-trace."""
