"""``params.malloc``: glibc keeps freed memory for reuse in a training process (rlchain.parallel.memory)."""

import copy
import platform
import subprocess
import sys

import pytest

from rlchain.config import ConfigError, parse_params
from rlchain.parallel import memory
from tests.conftest import BASE


class FakeLibc:
    def __init__(self, result=1):
        self.calls, self.result = [], result

    def mallopt(self, param, value):
        self.calls.append((param, value))
        return self.result


@pytest.fixture
def fresh(monkeypatch):
    monkeypatch.setattr(memory, "_applied", set())


def test_keep_raises_the_mmap_threshold_and_stops_trimming_once(monkeypatch, fresh):
    libc = FakeLibc()
    monkeypatch.setattr(memory, "_glibc", lambda: libc)
    assert memory.tune_malloc("keep") is True
    assert libc.calls == [(memory.M_MMAP_THRESHOLD, 32 * 1024 * 1024), (memory.M_TRIM_THRESHOLD, 2**31 - 1)]
    assert memory.tune_malloc("keep") is True and len(libc.calls) == 2  # once per process


def test_default_and_other_c_libraries_leave_malloc_alone(monkeypatch, fresh):
    libc = FakeLibc()
    monkeypatch.setattr(memory, "_glibc", lambda: libc)
    assert memory.tune_malloc("default") is False and libc.calls == []
    monkeypatch.setattr(memory, "_glibc", lambda: None)  # musl, macOS, Windows
    assert memory.tune_malloc("keep") is False


def test_a_refused_setting_is_one_warning(monkeypatch, fresh, caplog):
    monkeypatch.setattr(memory, "_glibc", lambda: FakeLibc(result=0))
    assert memory.tune_malloc("keep") is False
    assert any("mallopt refused" in r.getMessage() for r in caplog.records)


def test_params_malloc_is_keep_by_default_and_a_bad_value_is_one_line():
    assert parse_params(copy.deepcopy(BASE), "cfg.yaml").malloc == "keep"
    raw = copy.deepcopy(BASE)
    raw["params"]["malloc"] = "jemalloc"
    with pytest.raises(ConfigError, match=r"cfg.yaml: params\.malloc: expected keep or default, got 'jemalloc'"):
        parse_params(raw, "cfg.yaml")


# The baseline sets glibc's starting mmap threshold (128 KiB) explicitly: left to itself glibc raises it after the
# first freed mmapped block (its dynamic threshold), and whether the 4 MB temporaries then come back from the heap
# or fault again depends on the heap's layout in that process (0 or ~150k faults, about half and half), so the
# default alone is no reliable baseline. A threshold set by mallopt stays where it is.
FAULTS = """
import resource, torch
from rlchain.parallel import memory
from rlchain.parallel.memory import tune_malloc
x = torch.randn(16384, 64)
def step():  # an update's pattern: a few MB-sized temporaries, allocated and freed
    y = torch.nn.functional.silu(x) * 2.0
    return (y + 1.0).sum()
def faults():
    for _ in range(5):
        step()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(50):
        step()
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
assert memory._glibc().mallopt(memory.M_MMAP_THRESHOLD, 128 * 1024)
default = faults()
assert tune_malloc("keep")
print(default, faults())
"""


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc only")
def test_keep_stops_the_page_faults_of_reallocated_tensors():
    out = subprocess.run([sys.executable, "-c", FAULTS], capture_output=True, text=True, check=True)
    default, keep = (int(v) for v in out.stdout.split()[-2:])
    assert default > 10_000, (default, keep)  # 128 KiB threshold: every temporary is fresh pages
    assert keep < default / 5, (default, keep)  # kept: ~none
