"""A module-scoped pytest fixture for the JAX env tests (brax, playground)."""

import pytest


@pytest.fixture(scope="module", autouse=True)
def jax_compile_cache(tmp_path_factory):
    """JAX's persistent compile cache for this module: the env built again by play/resume (same
    shapes, same episode length) loads its compiled reset/step instead of compiling them again. XLA's
    expensive optimisation passes are off for the module: the tests step an env for tens of steps, so
    compiling its reset and step costs far more than running them (about a quarter less CPU for
    Playground's CartpoleBalance, the same observations)."""
    import jax

    keys = ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs",
            "jax_persistent_cache_min_entry_size_bytes", "jax_disable_most_optimizations")
    before = {key: jax.config.values[key] for key in keys}  # (the last is not a jax.config attribute)
    jax.config.update("jax_compilation_cache_dir", str(tmp_path_factory.mktemp("jax_cache")))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    jax.config.update("jax_disable_most_optimizations", True)
    yield
    for key, value in before.items():
        jax.config.update(key, value)
