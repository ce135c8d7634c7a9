"""Hypothesis profiles for the property and fuzz tests.

    $ pytest                                   # "dev": 50 random examples per test
    $ CI=true pytest                           # "ci": 25 derandomized examples, reproducible
    $ HYPOTHESIS_PROFILE=thorough pytest       # "thorough": 1000 examples, for local hunting

``ci`` is chosen when the environment variable CI is set to anything but "", "0" or
"false" (CI services set CI=true), unless HYPOTHESIS_PROFILE names a profile. It is
derandomized, so a CI failure is the same failure on every rerun and on a laptop
(``CI=true pytest ...``), and it prints the reproduction blob. It keeps the whole
hypothesis suite within about a minute on two cores. No profile has a deadline: a
reference run's time depends on how many impacts the drawn scene has (a chatter at
R = 0.9 takes a few hundred), not on a regression.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])

settings.register_profile("dev", max_examples=50, **_COMMON)
settings.register_profile("ci", max_examples=25, derandomize=True, print_blob=True, **_COMMON)
settings.register_profile("thorough", max_examples=1000, print_blob=True, **_COMMON)


def _profile() -> str:
    chosen = os.environ.get("HYPOTHESIS_PROFILE")
    if chosen:
        return chosen
    if os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):
        return "ci"
    return "dev"


settings.load_profile(_profile())
