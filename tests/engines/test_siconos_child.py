"""Siconos's child process when it misbehaves: held to the run's time limit, killed when it sends garbage, a bad probe.

No Siconos is needed: the pythons here answer the probe with a version (``plugin_cases.FAKE_PYTHONS``)
and then do something else than the child. Each run is in a process of its own (a deadlock or a hang
would otherwise be this test's): before, the garbage child deadlocked (``Child.failure`` waited on a
child blocked writing to a full pipe), the sleeping one hung ``run`` with no limit, and a probe answered
in bytes that are not UTF-8 was a ``UnicodeDecodeError`` traceback (issue 34).
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from plugin_cases import ENV, NOT_UTF8, install

RUN = ("import sys\nfrom chatterbench.engines.isolate import set_run_limit\n"
       "from chatterbench.engines.siconos_engine import SiconosEngine, SiconosSettings\n"
       "from chatterbench.reference.scene import load_scene\n"
       "set_run_limit(float(sys.argv[1]))\n"
       "traj = SiconosEngine().run(load_scene('bouncing-ball', ['duration=0.1']), SiconosSettings(dt=1e-3))\n"
       "print(traj.status, '|', traj.message)\n")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    return install(tmp_path_factory.mktemp("pythons"), names=())


def _run(site, python: str, limit: float = 600.0) -> tuple[str, str]:
    done = subprocess.run([sys.executable, "-c", RUN, str(limit)], capture_output=True, text=True, timeout=120,
                          env={**os.environ, ENV: str(site / python)})
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr[-2000:]
    status, _, message = done.stdout.strip().partition(" | ")
    return status, message


def test_a_child_that_never_answers_is_killed_at_the_runs_limit(site):
    status, message = _run(site, "python-sleeps", limit=1.0)  # a child that only sleeps: 1 s is enough to wait
    assert status == "timeout"
    assert message == "siconos: SiconosTimeout: the Siconos child ran past the run's time limit of 1 s and was killed"


def test_a_child_that_writes_garbage_until_its_pipe_is_full_is_killed_not_waited_for(site):
    status, message = _run(site, "python-garbage")
    assert status == "error"
    assert message.startswith("siconos: SiconosFailure: the Siconos child sent what is not the protocol and was killed; "
                              "a frame of "), message


def test_a_probe_answered_in_bytes_that_are_not_utf8_is_one_line(site):
    from chatterbench.engines.siconos_engine.run import _probe

    reason = _probe(str(site / NOT_UTF8))
    assert isinstance(reason, str) and "answered the Siconos probe with bytes that are not UTF-8" in reason
    assert "\n" not in reason
    assert _probe(str(site / "python-sleeps")).version == "4.5.0"  # a version is a version (the fake passes)
