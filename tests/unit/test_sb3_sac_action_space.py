"""The SB3 face's SAC takes Box actions only, as SB3's SAC does (rlchain's own SAC also trains Discrete ones)."""

import pytest

import rlchain
from rlchain.config.errors import ConfigError


def test_sb3_sac_on_discrete_actions_is_a_one_line_error_as_in_sb3(tmp_path):
    with pytest.raises(ConfigError, match=r"rlchain.SAC: env: SB3's SAC supports Box actions only, the env has "
                                          r"Discrete\(2\)") as err:
        rlchain.SAC("MlpPolicy", "CartPole-v1", verbose=0, tensorboard_log=str(tmp_path))
    assert "\n" not in str(err.value)
