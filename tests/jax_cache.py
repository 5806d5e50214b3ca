"""A module-scoped pytest fixture for the JAX env tests (brax, playground)."""

import pytest


@pytest.fixture(scope="module", autouse=True)
def jax_compile_cache():
    """XLA's expensive optimisation passes off for this module: the tests step an env for tens of steps, so
    compiling its reset and step costs far more than running them (about a quarter less CPU for Playground's
    CartpoleBalance, the same observations; Brax's reset and step 15 CPU s against 30). The env's compiled
    functions are reused within the process (``build_key`` in rlchain/envs/backends/jax_batch.py) and across runs
    through the test run's persistent compile cache (tests/conftest.py's ``pytest_configure``)."""
    import jax

    before = jax.config.values["jax_disable_most_optimizations"]  # (not a jax.config attribute)
    jax.config.update("jax_disable_most_optimizations", True)
    yield
    jax.config.update("jax_disable_most_optimizations", before)
