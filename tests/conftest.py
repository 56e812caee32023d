"""The ``--hard`` option, the project's hypothesis profiles and the ``paper`` fixture. The shared
helpers themselves (scene builders, the hard-mode switch, ...) are in tests/helpers.py."""

import copy
import os

import pytest
from hypothesis import HealthCheck, settings

from helpers import PAPER, hard_mode, paper_scene, two_cars  # noqa: F401  (``from conftest import``)

# Hypothesis: a case's run time depends on its numbers (a stiff contact takes more steps), so no
# per-example deadline and no too-slow health check; tests that need others say so themselves.
# The default run is derandomized (the same generated cases on every run and every machine:
# a CI failure can be reproduced, and one run that passes passes again); hard mode (--hard or
# LSC_HARD=1) draws new random cases each run, to find what the fixed ones do not.
settings.register_profile("lsc", deadline=None, suppress_health_check=[HealthCheck.too_slow],
                          derandomize=True)
settings.register_profile("lsc-hard", deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("lsc")
# While developing a property: `pytest --hypothesis-profile=dev` reports every distinct failure
# at once, unshrunk (shrinking a slow case can take many minutes).
settings.register_profile("dev", deadline=None, suppress_health_check=list(HealthCheck),
                          report_multiple_bugs=True,
                          phases=["explicit", "reuse", "generate", "target"])


def pytest_addoption(parser):
    parser.addoption("--hard", action="store_true", default=False,
                     help="hard-case mode: run the hard-case suite (tests/hard) and the loader "
                          "fuzzing with many more generated cases (same as LSC_HARD=1)")


def pytest_configure(config):
    # set before the test modules are imported: their hypothesis settings read it
    if config.getoption("--hard"):
        os.environ["LSC_HARD"] = "1"
    if hard_mode():
        settings.load_profile("lsc-hard")
    else:
        _without_local_constants()


def _without_local_constants():
    """Keep the derandomized cases fixed by the tests alone: Hypothesis (from 6.131) also draws,
    now and then, literals it collects from the local modules loaded so far (``lsc``'s, the
    tests'), so a case would change with any number written anywhere in the code, and with the
    test files that ran before it. The default run draws from Hypothesis's own constants only;
    hard mode keeps the local ones (they help find new cases). Nothing is changed where this
    Hypothesis has no such pool (an internal name; checked)."""
    try:
        from hypothesis.internal.conjecture import providers
    except ImportError:
        return
    pool = getattr(providers, "_local_constants", None)
    if pool is None or not hasattr(providers, "_get_local_constants"):
        return
    empty = copy.deepcopy(pool)
    for name in ("integers", "floats", "bytes", "strings"):
        getattr(empty, name).clear()
    providers._get_local_constants = lambda: empty
    providers.CONSTANTS_CACHE.cache.clear()


@pytest.fixture
def paper():
    """The paper's two-car scene (a fresh copy: a test may change it)."""
    return copy.deepcopy(PAPER)
