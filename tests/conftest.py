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


@pytest.fixture
def paper():
    """The paper's two-car scene (a fresh copy: a test may change it)."""
    return copy.deepcopy(PAPER)
