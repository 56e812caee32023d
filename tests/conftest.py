"""Shared scene builders for the tests (plain dicts, in the scene format of DESIGN.md §4), the
``--hard`` option and the project's hypothesis profile."""

import copy
import os

import pytest
from hypothesis import HealthCheck, settings

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
    if os.environ.get("LSC_HARD", "").strip().lower() not in ("", "0", "false", "no"):
        settings.load_profile("lsc-hard")


PAPER = {
    "name": "paper",
    "units": "US",
    "g": "32.2 ft/s^2",
    "vehicles": [
        {"name": "bullet", "weight": 3500, "speed": 10},
        {"name": "target", "weight": 3500, "speed": 0},
    ],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}],
}


def paper_scene(**changes):
    """The paper's two-car scene with dotted-path changes, e.g. ``paper_scene(**{"vehicles.0.speed": 5})``."""
    s = copy.deepcopy(PAPER)
    for path, value in changes.items():
        obj = s
        keys = path.split(".")
        for key in keys[:-1]:
            obj = obj[int(key)] if key.isdigit() else obj[key]
        last = keys[-1]
        if last.isdigit():
            obj[int(last)] = value
        else:
            obj[last] = value
    return s


def two_cars(m1, m2, v1, v2, loading, unloading, gap=0.0, units="SI"):
    """A two-vehicle scene dict with masses (not weights)."""
    return {
        "units": units,
        "vehicles": [{"mass": m1, "speed": v1}, {"mass": m2, "speed": v2}],
        "contacts": [{"loading": loading, "unloading": unloading, "gap": gap}],
    }


@pytest.fixture
def paper():
    return copy.deepcopy(PAPER)
