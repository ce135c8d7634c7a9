"""Shared runs of the reference: each catalogue scene is simulated once per chatter mode."""

from __future__ import annotations

import functools

import pytest

from chatterbench.reference import load_scene, simulate

CATALOGUE_NAMES = ("bouncing-ball", "feigin-pair", "impact-damper", "spring-pair")
MODES = ("feigin", "exhaustive")


@functools.lru_cache(maxsize=None)
def run(name: str, mode: str, overrides: tuple[str, ...] = ()):
    """The reference result for a catalogue scene (cached: results are bit-identical per input)."""
    return simulate(load_scene(name, list(overrides)), mode)


@pytest.fixture(params=CATALOGUE_NAMES)
def scene_name(request) -> str:
    return request.param


@pytest.fixture(params=MODES)
def mode(request) -> str:
    return request.param
