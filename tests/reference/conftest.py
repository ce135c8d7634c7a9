"""The reference tests' scene and chatter-mode fixtures (their shared runs: ``helpers.reference_run``)."""

from __future__ import annotations

import pytest

CATALOGUE_NAMES = ("bouncing-ball", "feigin-pair", "impact-damper", "spring-pair")
MODES = ("feigin", "exhaustive")


@pytest.fixture(params=CATALOGUE_NAMES)
def scene_name(request) -> str:
    return request.param


@pytest.fixture(params=MODES)
def mode(request) -> str:
    return request.param
