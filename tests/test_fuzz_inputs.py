"""Fuzzed input files: whatever the bytes, a clean refusal or a valid object, never a traceback.

Inputs: every catalogue scene written as TOML, then truncated at random byte offsets,
with random bytes flipped, keys renamed, values swapped for wrong types (strings, tables,
arrays, booleans, dates), NaN/inf and huge numbers, required fields dropped; empty files,
binary garbage; random ``--set`` items; and the example sweep specs of ``examples/sweeps``
under the same damage (``comparisons/sweep.py``'s ``load_sweep``, ``SpecError``); and the
gate file ``gates/default.toml`` (``comparisons/gate.py``'s ``load_gate``, ``GateError``).

The contract checked:

- ``load_scene`` / ``load_sweep`` return a ``Scene`` / ``Sweep`` or raise ``SceneError``
  (``SpecError`` is one) with a one-line message; any other exception fails the test;
- a refused input through the CLI (``chatterbench run FILE``, ``chatterbench sweep SPEC``)
  exits 2 with exactly one stderr line ``chatterbench: error: ...`` and no traceback;
- gate files are the exception to "one line": ``GateError`` lists every problem of the
  file, one per line, by design; the CLI (``chatterbench gate FILE``) must still exit 2
  with stderr starting ``chatterbench: error:`` and no traceback, UTF-8 or not.

Accepted inputs are not run through the CLI: a fuzzed but valid scene may ask for a huge
run (``duration = 1e12``), which is not an input error; absurd but valid values the
reference cannot finish are refused at run time (``test_bad_inputs.py``).
"""

from __future__ import annotations

import copy
import json
import math
import re
import tomllib
from pathlib import Path

import pytest
from hypothesis import given, strategies as st

from chatterbench.reference.catalogue import CATALOGUE
from chatterbench.reference.scene import Scene, SceneError, load_scene

from helpers import cli, cli_process, needs_engine

REPO = Path(__file__).resolve().parents[1]
SWEEP_EXAMPLES = sorted((REPO / "examples" / "sweeps").glob("*.toml"))

from chatterbench.comparisons.ci.gate import Gate, GateError, load_gate
from chatterbench.comparisons.studies.sweep import Sweep, SpecError, load_sweep
GATE_FILES = sorted((REPO / "gates").glob("*.toml"))


# -- a TOML writer for any plain data (the fuzz must write what tomllib cannot) -----------
_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _string(s: str) -> str:
    # JSON escapes are TOML escapes; TOML also forbids a raw DEL
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if hasattr(v, "isoformat"):
        return v.isoformat()
    raise TypeError(v)


def to_toml(data: dict) -> str:
    """TOML text for a dict: scalars, then [tables], then [[arrays of tables]]."""
    lines, tables, arrays = [], [], []
    for k, v in data.items():
        if isinstance(v, dict) and v:
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays.append((k, v))
        else:
            lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in tables:
        lines.append(f"[{_key(k)}]")
        lines += [f"{_key(kk)} = {_value(vv)}" for kk, vv in v.items()]
    for k, v in arrays:
        for item in v:
            lines.append(f"[[{_key(k)}]]")
            lines += [f"{_key(kk)} = {_value(vv)}" for kk, vv in item.items()]
    return "\n".join(lines) + "\n"


SCENE_NAMES = sorted(CATALOGUE)
SCENE_BYTES = {name: to_toml(CATALOGUE[name]).encode() for name in SCENE_NAMES}


def test_writer_round_trips_the_catalogue(tmp_path):
    # the fuzz starts from valid files: each written scene loads back as the catalogue's
    for name in SCENE_NAMES:
        path = tmp_path / f"{name}.toml"
        path.write_bytes(SCENE_BYTES[name])
        assert load_scene(path) == load_scene(name)


# -- the contract -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def assert_clean_refusal(code: int, err: str) -> None:
    assert code == 2, (code, err)
    assert "Traceback" not in err, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("chatterbench: error: "), err


def check_scene_bytes(workdir: Path, content: bytes, *, via_cli: bool = True) -> Scene | None:
    """Load ``content`` as a scene file: a Scene, or a one-line SceneError (then, via the CLI: exit 2)."""
    path = workdir / "fuzzed.toml"
    path.write_bytes(content)
    try:
        scene = load_scene(path)
    except SceneError as exc:
        message = str(exc)
        assert message and "\n" not in message, message
        if via_cli:
            assert_clean_refusal(*cli(["run", str(path)])[::2])
        return None
    assert isinstance(scene, Scene)
    return scene


# -- damage to whole files ----------------------------------------------------------------
@given(name=st.sampled_from(SCENE_NAMES), cut=st.floats(0.0, 1.0))
def test_truncated_scene_files(workdir, name, cut):
    full = SCENE_BYTES[name]
    check_scene_bytes(workdir, full[: int(cut * len(full))])


def test_every_truncation_of_one_scene(workdir):
    # all offsets of the shortest file, loader only (the CLI path is the test above's)
    full = min(SCENE_BYTES.values(), key=len)
    for k in range(len(full) + 1):
        check_scene_bytes(workdir, full[:k], via_cli=False)


@given(name=st.sampled_from(SCENE_NAMES),
       flips=st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(0, 255)), min_size=1, max_size=4))
def test_byte_flips(workdir, name, flips):
    data = bytearray(SCENE_BYTES[name])
    for where, byte in flips:
        data[int(where * len(data))] = byte
    check_scene_bytes(workdir, bytes(data))


@given(content=st.binary(max_size=400))
def test_binary_garbage(workdir, content):
    check_scene_bytes(workdir, content)


@given(content=st.text(max_size=200))
def test_text_garbage(workdir, content):
    check_scene_bytes(workdir, content.encode("utf-8"))


def test_empty_file(workdir):
    assert check_scene_bytes(workdir, b"") is None


# -- damage to the data: keys, types, values ----------------------------------------------
def _leaves(data: dict, prefix=()) -> list[tuple]:
    """Paths to every scalar of a scene dict: ("gap", "lower"), ("forces", 0, "omega"), ..."""
    out = []
    for k, v in data.items():
        if isinstance(v, dict):
            out += _leaves(v, (*prefix, k))
        elif isinstance(v, list):
            for i, item in enumerate(v):
                out += _leaves(item, (*prefix, k, i))
        else:
            out.append((*prefix, k))
    return out


def _keys(data: dict, prefix=()) -> list[tuple]:
    """Paths to every key (tables and scalars)."""
    out = []
    for k, v in data.items():
        out.append((*prefix, k))
        if isinstance(v, dict):
            out += _keys(v, (*prefix, k))
        elif isinstance(v, list):
            for i, item in enumerate(v):
                if isinstance(item, dict):
                    out += _keys(item, (*prefix, k, i))
    return out


def _parent(data, path):
    for p in path[:-1]:
        data = data[p]
    return data


NUMERIC = {name: [p for p in _leaves(CATALOGUE[name]) if isinstance(_parent(CATALOGUE[name], p)[p[-1]], (int, float))]
           for name in SCENE_NAMES}
KEYS = {name: _keys(CATALOGUE[name]) for name in SCENE_NAMES}
REQUIRED = ("mass1", "mass2", "restitution", "gap")
FIELD_NAMES = {str(p[-1]) for name in SCENE_NAMES for p in KEYS[name]} | {
    "prescribed", "amplitude", "omega", "phase", "offset", "value", "stiffness", "rest", "damping", "kind", "on",
    "upper", "lower"}


@st.composite
def scene_and_path(draw, paths):
    name = draw(st.sampled_from(SCENE_NAMES))
    return name, copy.deepcopy(CATALOGUE[name]), draw(st.sampled_from(paths[name]))


# names without line breaks or control characters: a key holding a newline is echoed raw
# into the one-line message (a known bug, pinned in test_bad_inputs.py)
printable = st.characters(blacklist_categories=("Cc", "Cs", "Zl", "Zp"))
names = st.text(printable, min_size=1, max_size=12)

wrong_types = st.one_of(
    st.text(max_size=12),
    st.dictionaries(st.text(printable, min_size=1, max_size=5), st.integers(), max_size=2),
    st.lists(st.floats(allow_nan=False), max_size=3),
    st.booleans(),
    st.dates(),
)


@given(case=scene_and_path(KEYS), new=names)
def test_renamed_keys(workdir, case, new):
    name, data, path = case
    parent = _parent(data, path)
    old = path[-1]
    if new in parent:
        return  # renaming onto a sibling is a different file, not a rename
    parent[new] = parent.pop(old)
    path_in_file = workdir / "renamed.toml"
    path_in_file.write_text(to_toml(data))
    if new in FIELD_NAMES:
        check_scene_bytes(workdir, to_toml(data).encode())  # a real name elsewhere: anything clean goes
        return
    # an unknown name is refused, and the message names it, or the key it replaced (a
    # renamed force 'kind' reads "forces[0].kind = None: must be one of ...")
    with pytest.raises(SceneError) as exc:
        load_scene(path_in_file)
    assert new in str(exc.value) or repr(new) in str(exc.value) or str(old) in str(exc.value), (old, new, str(exc.value))
    assert_clean_refusal(*cli(["run", str(path_in_file)])[::2])


@given(case=scene_and_path(NUMERIC), value=wrong_types)
def test_wrong_types_for_numbers(workdir, case, value):
    name, data, path = case
    if path[-1] == "mass1" and isinstance(value, str) and value.strip().lower() in ("inf", "infinity"):
        return  # the one string a number field takes
    _parent(data, path)[path[-1]] = value
    path_in_file = workdir / "typed.toml"
    path_in_file.write_text(to_toml(data))
    with pytest.raises(SceneError) as exc:
        load_scene(path_in_file)
    # the message names the field (force parameters by name, sections by their key)
    assert str(path[-1]) in str(exc.value), (path, str(exc.value))
    assert_clean_refusal(*cli(["run", str(path_in_file)])[::2])


@given(case=scene_and_path(NUMERIC), value=st.sampled_from([math.nan, math.inf, -math.inf]))
def test_non_finite_numbers(workdir, case, value):
    name, data, path = case
    if path[-1] == "mass1" and value == math.inf:
        return  # an infinite body 1 is allowed (fixed or prescribed)
    _parent(data, path)[path[-1]] = value
    path_in_file = workdir / "nonfinite.toml"
    path_in_file.write_text(to_toml(data))
    with pytest.raises(SceneError, match=re.escape(str(path[-1]))):
        load_scene(path_in_file)
    assert_clean_refusal(*cli(["run", str(path_in_file)])[::2])


@given(case=scene_and_path(NUMERIC), value=st.sampled_from([1e308, -1e308, 1e300, -1e300, 5e-324, 2**63 - 1, -(2**63)]))
def test_huge_and_tiny_numbers(workdir, case, value):
    # accepted (a valid, if absurd, scene) or refused with a clean message, never a crash
    name, data, path = case
    _parent(data, path)[path[-1]] = value
    check_scene_bytes(workdir, to_toml(data).encode())


@given(name=st.sampled_from(SCENE_NAMES), drop=st.sets(st.sampled_from(REQUIRED), min_size=1))
def test_missing_required_fields(workdir, name, drop):
    data = {k: v for k, v in CATALOGUE[name].items() if k not in drop}
    path = workdir / "missing.toml"
    path.write_text(to_toml(data))
    with pytest.raises(SceneError, match="missing") as exc:
        load_scene(path)
    assert any(k in str(exc.value) for k in drop)
    assert_clean_refusal(*cli(["run", str(path)])[::2])


# -- --set items ----------------------------------------------------------------------------
SET_KEYS = ["restitution", "mass1", "mass2", "duration", "gap.lower", "gap.upper", "initial.t", "initial.y", "initial.vy",
            "forces.0.amplitude", "forces.0.omega", "forces.1.stiffness", "forces.9.omega", "prescribed.omega", "name",
            "gap", "forces", "forces.x.y", "initial.z", "mujoco.dt", "mujoco.nope", "pybullet.dt", ""]
set_values = st.one_of(st.sampled_from(["", "nan", "inf", "-inf", "1e999", "-1", "0", "[1, 2]", "{a = 1}", "true", '"x"', "=",
                                        "1e308", "abc", "0x10", "1_000"]),
                       st.text(printable, max_size=10))


@given(name=st.sampled_from(SCENE_NAMES),
       items=st.lists(st.one_of(st.builds(lambda k, v: f"{k}={v}", st.sampled_from(SET_KEYS), set_values),
                                st.text(printable, max_size=15)), min_size=1, max_size=3))
def test_set_overrides(name, items):
    """Random ``--set`` items: a Scene or a one-line SceneError; refused ones exit 2 via the CLI.

    Engine settings (``mujoco.*``) go to the engine, so they are checked with the engine
    given; the reference refuses them with a UsageError (also exit 2).
    """
    scene_items = [i for i in items if not i.split("=")[0].strip().startswith(("mujoco.", "pybullet."))]
    try:
        load_scene(name, scene_items)
        refused = False
    except SceneError as exc:
        assert "\n" not in str(exc)
        refused = True
    if refused or len(scene_items) < len(items):
        argv = ["run", name]
        for item in items:
            argv += ["--set", item]
        assert_clean_refusal(*cli(argv)[::2])


# -- sweep specs ------------------------------------------------------------------------------
SWEEP_BYTES = {p.name: p.read_bytes() for p in SWEEP_EXAMPLES}


def check_sweep_bytes(workdir: Path, content: bytes, *, via_cli: bool = True):
    path = workdir / "fuzzed-sweep.toml"
    path.write_bytes(content)
    try:
        sweep = load_sweep(path)
    except SpecError as exc:
        assert str(exc) and "\n" not in str(exc), str(exc)
        if via_cli:
            # refused before any engine starts, so --out is never written
            assert_clean_refusal(*cli(["sweep", str(path), "--out", str(workdir / "never")])[::2])
        return None
    assert isinstance(sweep, Sweep)
    return sweep


@pytest.mark.parametrize("path", SWEEP_EXAMPLES, ids=[p.stem for p in SWEEP_EXAMPLES])
def test_sweep_examples_load(path):
    assert SWEEP_EXAMPLES and GATE_FILES  # the fuzz below damages these files
    needs_engine(*tomllib.loads(path.read_text(encoding="utf-8")).get("engines", ()))  # an example of an absent engine
    assert isinstance(load_sweep(path), Sweep)


@given(name=st.sampled_from(sorted(SWEEP_BYTES)), cut=st.floats(0.0, 1.0))
def test_truncated_sweep_specs(workdir, name, cut):
    full = SWEEP_BYTES[name]
    check_sweep_bytes(workdir, full[: int(cut * len(full))])


@given(name=st.sampled_from(sorted(SWEEP_BYTES)),
       flips=st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(0, 255)), min_size=1, max_size=4))
def test_sweep_byte_flips(workdir, name, flips):
    data = bytearray(SWEEP_BYTES[name])
    for where, byte in flips:
        data[int(where * len(data))] = byte
    check_sweep_bytes(workdir, bytes(data))


@given(content=st.one_of(st.binary(max_size=300), st.text(max_size=200).map(str.encode)))
def test_sweep_garbage(workdir, content):
    check_sweep_bytes(workdir, content)


@given(key=st.sampled_from(["scene", "engines", "timeout", "description", "set", "grid", "points", "tolerances"]),
       value=st.one_of(wrong_types, st.floats(), st.just([]), st.just({})))
def test_sweep_wrong_types(workdir, key, value):
    import tomllib

    data = tomllib.loads(SWEEP_BYTES[sorted(SWEEP_BYTES)[0]].decode())
    data[key] = value
    check_sweep_bytes(workdir, to_toml(data).encode())


# -- gate files --------------------------------------------------------------------------------
GATE_BYTES = {p.name: p.read_bytes() for p in GATE_FILES}


def check_gate_bytes(workdir: Path, content: bytes, *, via_cli: bool = True):
    path = workdir / "fuzzed-gate.toml"
    path.write_bytes(content)
    try:
        gate = load_gate(path)
    except GateError as exc:
        assert str(exc), "empty message"
        if via_cli:
            code, _, err = cli(["gate", str(path)])
            assert code == 2, (code, err)
            assert "Traceback" not in err and err.startswith("chatterbench: error: "), err
        return None
    assert isinstance(gate, Gate)
    return gate


@given(name=st.sampled_from(sorted(GATE_BYTES)), cut=st.floats(0.0, 1.0))
def test_truncated_gate_files(workdir, name, cut):
    full = GATE_BYTES[name]
    check_gate_bytes(workdir, full[: int(cut * len(full))])


@given(name=st.sampled_from(sorted(GATE_BYTES)),
       flips=st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(0, 255)), min_size=1, max_size=4))
def test_gate_byte_flips(workdir, name, flips):
    data = bytearray(GATE_BYTES[name])
    for where, byte in flips:
        data[int(where * len(data))] = byte
    check_gate_bytes(workdir, bytes(data))


@given(content=st.text(max_size=200))
def test_gate_text_garbage(workdir, content):
    check_gate_bytes(workdir, content.encode("utf-8"))


@given(key=st.sampled_from(["name", "scene", "engine", "dt", "settings", "scene_overrides", "tolerances", "limits"]),
       value=st.one_of(wrong_types, st.floats(), st.just([]), st.just({}), st.just(["verdict == nope"]),
                       st.just(["exit_error_max <= nan"]), st.just({"w0_dt": 99.0}), st.just({"restitution": 2.0})))
def test_gate_wrong_values(workdir, key, value):
    import tomllib

    data = tomllib.loads(GATE_BYTES[sorted(GATE_BYTES)[0]].decode())
    data["check"][0][key] = value
    check_gate_bytes(workdir, to_toml(data).encode())


def test_gate_file_not_utf8(tmp_path):
    path = tmp_path / "gate.toml"
    path.write_bytes(b"\xff\xfe\x00garbage")
    code, _, err = cli(["gate", str(path)])
    assert code == 2 and err.startswith("chatterbench: error: "), err


# -- a couple through a real process: the console entry point, stderr as a user sees it --------
@pytest.mark.parametrize("content", [b"mass1 = \n", b"\x00\xff\xfe garbage", b"[gap]\nlower = 'a'\n"])
def test_cli_subprocess_refuses_cleanly(tmp_path, content):
    path = tmp_path / "bad.toml"
    path.write_bytes(content)
    proc = cli_process("run", str(path), timeout=120)
    assert_clean_refusal(proc.returncode, proc.stderr)
    assert proc.stdout == ""
