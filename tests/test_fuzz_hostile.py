"""Hostile inputs for the three file readers (scene, sweep spec, gate file): nesting, sizes, file types, Unicode.

Issue 25: nesting bombs raised ``RecursionError`` (or took tomllib seconds: a dotted key
20000 deep), ``/dev/zero`` and named pipes were read until memory ran out or waited on for
ever. Hypothesis draws the depth (1 to 6000), the kind of nesting (arrays, inline tables,
dotted keys, quoted dotted keys) and where it goes in a valid file, file sizes on either side
of the 10 MiB bound, the kind of file (a named pipe, a directory, a device, a link to one) and
Unicode keys and values (control characters, emoji, right-to-left marks). The contract, for
each reader and through the CLI: a value, or the reader's own error (``SceneError``,
``SpecError``, ``GateError``) and exit 2 with stderr starting ``chatterbench: error:``; nothing
else escapes, and every refusal is quick (no read of a device, no wait on a pipe).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from chatterbench.comparisons.ci.gate import GateError, load_gate
from chatterbench.comparisons.studies.sweep import SpecError, load_sweep
from chatterbench.reference.scene import SceneError, load_scene
from chatterbench.reference.tables import MAX_DEPTH, MAX_FILE_BYTES

from helpers import cli
from test_fuzz_inputs import (GATE_BYTES, SCENE_BYTES, SWEEP_BYTES, assert_clean_refusal, check_gate_bytes,
                              check_scene_bytes, check_sweep_bytes)

SCENE = SCENE_BYTES["feigin-pair"].decode()
SWEEP = SWEEP_BYTES[sorted(SWEEP_BYTES)[0]].decode()
GATE = GATE_BYTES[sorted(GATE_BYTES)[0]].decode()
CHECKS = {"scene": check_scene_bytes, "sweep": check_sweep_bytes, "gate": check_gate_bytes}
TEXTS = {"scene": SCENE, "sweep": SWEEP, "gate": GATE}


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("hostile")


HOSTILE = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def nested(kind: str, depth: int) -> str:
    """A TOML line ``KEY = VALUE`` (or a dotted key) nested ``depth`` deep."""
    if kind == "arrays":
        return "bomb = " + "[" * depth + "1" + "]" * depth
    if kind == "tables":
        return "bomb = " + "{a = " * depth + "1" + "}" * depth
    if kind == "dotted":
        return "a" + ".a" * depth + " = 1"
    return "'a'" + ".'a'" * depth + " = 1"  # quoted parts


@HOSTILE
@given(reader=st.sampled_from(sorted(CHECKS)), kind=st.sampled_from(["arrays", "tables", "dotted", "quoted"]),
       depth=st.one_of(st.integers(1, 2 * MAX_DEPTH), st.integers(2 * MAX_DEPTH, 6000)), first=st.booleans())
def test_nesting_of_any_depth_is_refused_or_read(workdir, reader, kind, depth, first):
    line = nested(kind, depth)
    text = TEXTS[reader]
    content = f"{line}\n{text}" if first else f"{text}\n{line}\n"  # at the top, or inside the file's last table
    CHECKS[reader](workdir, content.encode(), via_cli=depth > MAX_DEPTH)
    if depth > MAX_DEPTH:  # refused by the depth scan, before tomllib reads it (it took 4 s on a dotted key 20000 deep)
        path = workdir / "deep.toml"
        path.write_text(content)
        load, error, _ = LOADERS[reader]
        with pytest.raises(error, match=f"nested more than {MAX_DEPTH}"):
            load(path)


@HOSTILE
@given(depth=st.integers(MAX_DEPTH + 1, 6000), kind=st.sampled_from(["arrays", "tables"]))
def test_nesting_in_a_set_value_is_refused(depth, kind):
    value = nested(kind, depth).split(" = ", 1)[1]
    code, _, err = cli(["run", "feigin-pair", "--set", f"gap.lower={value}"])
    assert_clean_refusal(code, err)
    assert f"nested more than {MAX_DEPTH}" in err


@HOSTILE
@given(reader=st.sampled_from(sorted(CHECKS)),
       key=st.text(min_size=1, max_size=40), value=st.text(max_size=200),
       place=st.sampled_from(["key", "value", "both"]))
def test_unicode_keys_and_values(workdir, reader, key, value, place):
    from test_fuzz_inputs import _key, _string

    k = _key(key) if place in ("key", "both") else "description"
    v = _string(value) if place in ("value", "both") else "1"
    CHECKS[reader](workdir, f"{k} = {v}\n{TEXTS[reader]}".encode())


LOADERS = {"scene": (load_scene, SceneError, "run"), "sweep": (load_sweep, SpecError, "sweep"),
           "gate": (load_gate, GateError, "gate")}


def _refused_quickly(reader: str, path: Path, *words: str) -> None:
    load, error, command = LOADERS[reader]
    with pytest.raises(error) as exc:
        load(path)
    for word in words:
        assert word in str(exc.value), str(exc.value)
    code, _, err = cli([command, str(path)])
    assert code == 2 and err.startswith("chatterbench: error: ") and "Traceback" not in err, err


@pytest.fixture
def places(tmp_path) -> dict[str, Path]:
    """A named pipe (no writer: a read would wait for ever), a directory, devices, and links to them."""
    os.mkfifo(tmp_path / "pipe.toml")
    (tmp_path / "dir.toml").mkdir()
    for name, target in (("zero.toml", "/dev/zero"), ("urandom.toml", "/dev/urandom"), ("to-pipe.toml", "pipe.toml")):
        (tmp_path / name).symlink_to(target)
    return {p.name: p for p in tmp_path.iterdir()} | {"/dev/zero": Path("/dev/zero"), "/dev/null": Path("/dev/null")}


@pytest.mark.parametrize("reader", sorted(LOADERS))
@pytest.mark.parametrize("place", ["pipe.toml", "to-pipe.toml", "zero.toml", "urandom.toml", "/dev/zero", "/dev/null"])
def test_a_device_or_pipe_is_refused_unread(places, reader, place):
    _refused_quickly(reader, places[place], "not a regular file")


@pytest.mark.parametrize("reader", sorted(LOADERS))
def test_a_directory_is_refused(places, reader):
    _refused_quickly(reader, places["dir.toml"], "is a directory")


@pytest.mark.parametrize("reader", sorted(LOADERS))
@pytest.mark.parametrize("extra", [-1, 1])  # a comment pads the file to just under, or just over, the bound
def test_the_size_bound(tmp_path, reader, extra):
    text = TEXTS[reader] + "\n#"
    path = tmp_path / "big.toml"
    path.write_text(text + "x" * (MAX_FILE_BYTES + extra - len(text.encode())))
    if extra > 0:
        _refused_quickly(reader, path, "10 MiB")
    else:
        LOADERS[reader][0](path)  # read: at the bound is allowed


# -- baselines (gate --baseline FILE.json): read like the others, validated whole before any run ----------------
GATE_ONE = ('[[check]]\nscene = "bouncing-ball"\nengine = "pybullet"\nscene_overrides = { duration = 0.2 }\n'
            'limits = ["status == ok"]\n')
BASE = {"format": "chatterbench-gate-baseline/1", "gate": "g.toml", "created": "2026-01-01T00:00:00+00:00",
        "versions": {"pybullet": "3.2.6"}, "checks": {"bouncing-ball/pybullet": {"exit_error_max": 0.001, "verdict": "match"}}}
BAD_BASELINES = {  # before: the 100k-deep one raised RecursionError, the others AttributeError after the whole gate ran
    "nested 100k deep": "[" * 100_000 + "]" * 100_000,
    "versions a string": {**BASE, "versions": "pybullet 3.2.6"},
    "a check a list": {**BASE, "checks": {"bouncing-ball/pybullet": [1, 2]}},
    "a check a number": {**BASE, "checks": {"bouncing-ball/pybullet": 3}},
    "a metric a string": {**BASE, "checks": {"bouncing-ball/pybullet": {"exit_error_max": "small"}}},
    "checks an array": {**BASE, "checks": [1]},
    "a version a table": {**BASE, "versions": {"pybullet": {"v": 1}}},
}


def _gate_with_baseline(tmp_path: Path, baseline) -> tuple[int, str]:
    (tmp_path / "g.toml").write_text(GATE_ONE)
    (tmp_path / "b.json").write_text(baseline if isinstance(baseline, str) else json.dumps(baseline))
    code, _, err = cli(["gate", str(tmp_path / "g.toml"), "--baseline", str(tmp_path / "b.json")])
    return code, err


@pytest.mark.parametrize("case", sorted(BAD_BASELINES))
def test_a_bad_baseline_is_refused_before_any_run(tmp_path, case, engine_runs):
    code, err = _gate_with_baseline(tmp_path, BAD_BASELINES[case])
    assert_clean_refusal(code, err)
    assert "--baseline" in err, err
    assert engine_runs() == []


@pytest.mark.parametrize("place", ["pipe.toml", "zero.toml", "/dev/zero", "dir.toml"])
def test_a_baseline_that_is_no_file_is_refused_unread(places, tmp_path, place, engine_runs):
    (tmp_path / "g.toml").write_text(GATE_ONE)
    code, _, err = cli(["gate", str(tmp_path / "g.toml"), "--baseline", str(places[place])])
    assert_clean_refusal(code, err)
    assert engine_runs() == []


JSON = st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3),
                    max_leaves=12)


@HOSTILE
@given(field=st.sampled_from(["format", "gate", "created", "versions", "checks", "check", "metric", "verdict"]),
       value=JSON)
def test_an_accepted_baseline_never_fails_later(tmp_path_factory, field, value):
    # validated whole on reading: whatever it accepts, the comparison and the versions note take without an error
    from chatterbench.comparisons.ci.baseline import BaselineError, check_regressions, load_baseline, versions_note

    data = json.loads(json.dumps(BASE))
    if field == "check":
        data["checks"]["bouncing-ball/pybullet"] = value
    elif field in ("metric", "verdict"):
        data["checks"]["bouncing-ball/pybullet"]["exit_error_max" if field == "metric" else "verdict"] = value
    else:
        data[field] = value
    path = tmp_path_factory.mktemp("base") / "b.json"
    path.write_text(json.dumps(data))
    try:
        base = load_baseline(path)
    except BaselineError as exc:
        assert str(exc).startswith(f"--baseline {path}") and "\n" not in str(exc), str(exc)
        return
    check_regressions("bouncing-ball/pybullet", {"exit_error_max": 0.002}, base)
    versions_note({"pybullet": "3.2.6"}, base)
