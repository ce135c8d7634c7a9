"""Third parties' engines, each in its own package installed with pip into a fresh venv: found, checked and judged.

Each passes chatterbench's shipped contract suite, run as its author runs it (``python -m pytest
--chatterbench-engine NAME`` in an empty folder: the installed package's pytest plugin, no file of
this repository).

Two packages: the engine the plugin how-to (``docs/how-to/plugin.md``) gives whole (its code
block and its ``pyproject.toml`` block, written to a temporary folder as a user would copy them:
nothing else is read) and ``examples/engine_plugin`` (pymunk); beside them, the plugin how-to's engine with a
wrong restitution (a known answer the other way), written as pip writes a package
(``plugin_cases.write_installed``). The venv is made from the running
interpreter with ``--system-site-packages`` and sees the running environment's packages even
when the tests themselves run in a venv (whose packages ``--system-site-packages`` alone would
not give it: it gives the base interpreter's); the repository's environment is never changed.
The commands run in the new venv's interpreter, as a user's shell would run them.
"""

from __future__ import annotations

import re
import site
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from plugin_cases import readme_block, write_installed

pytest.importorskip("pymunk", reason="pymunk is in the test extra: pip install '.[test]'")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "engine_plugin"
HOWTO = Path(__file__).resolve().parents[2] / "docs" / "how-to" / "plugin.md"


def _run(*args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=300, **kw)


def fresh_venv(where: Path) -> Path:
    """A venv at ``where`` made from this interpreter that sees this environment's packages; its python."""
    assert _run(sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", where).returncode == 0
    python = where / "bin" / "python"
    purelib = site_packages(python)
    # this environment's own site folders (a venv's, or the base's), processed as site folders (their .pth files
    # too: an editable install of chatterbench), after the new venv's own
    ours = [p for p in dict.fromkeys([*site.getsitepackages(), sysconfig.get_paths()["purelib"]]) if Path(p).is_dir()]
    Path(purelib, "zz_running_environment.pth").write_text(
        "".join(f"import site; site.addsitedir({p!r})\n" for p in ours))
    return python


def site_packages(python: Path) -> Path:
    """The folder where ``python`` installs packages (its venv's site-packages)."""
    return Path(_run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])").stdout.strip())


def _builds_wheels_here() -> bool:
    """Whether this environment's setuptools can build a wheel by itself (it has ``wheel``, or is 70.1 or later)."""
    import importlib.metadata
    import importlib.util

    try:
        major, minor = (int(p) for p in importlib.metadata.version("setuptools").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return False
    return importlib.util.find_spec("wheel") is not None or (major, minor) >= (70, 1)


def pip_install(python: Path, *packages: Path, cwd: Path) -> None:
    """``pip install`` ``packages`` into ``python``'s venv as a user would, with this environment's pip: its own
    setuptools builds them where it can (nothing downloaded), else pip's isolated builds (the package index)."""
    build = ["--no-build-isolation", "--no-index"] if _builds_wheels_here() else []
    done = _run(sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-deps", *build, *packages, cwd=cwd)
    assert done.returncode == 0, done.stdout + done.stderr


def cli(python: Path, *args, cwd: Path) -> subprocess.CompletedProcess:
    return _run(python, "-m", "chatterbench.comparisons.cli", *args, cwd=cwd)


def summary(done: subprocess.CompletedProcess, engine: str, column: str) -> str:
    """``column`` of ``engine``'s row of the summary ``compare`` prints."""
    lines = done.stdout.split("summary:")[1].splitlines()
    header = lines[1].split()
    row = next(ln.split() for ln in lines[2:] if ln.split() and ln.split()[0] == engine)
    return row[header.index(column)]


def euler_wrong() -> str:
    """Known answer the other way: the plugin how-to's engine with every impact at 0.8 R, as engine ``euler_wrong`` of
    package ``chatterbench-euler-wrong`` (its module's source)."""
    code = readme_block("# chatterbench_euler.py").replace("self.R, self.dt = scene.mass1, scene.mass2, scene.restitution",
                                                           "self.R, self.dt = scene.mass1, scene.mass2, 0.8 * scene.restitution")
    code = code.replace('"euler', '"euler_wrong').replace("chatterbench-euler", "chatterbench-euler-wrong")
    assert "0.8 * scene.restitution" in code
    return code


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A fresh venv with the how-to's engine (``euler``) and the example's (``pymunk``) installed by pip, and the
    plugin how-to's engine made wrong (``euler_wrong``) written beside them as pip writes a package; its python."""
    root = tmp_path_factory.mktemp("plugins")
    python = fresh_venv(root / "venv")
    before = cli(python, "compare", "bouncing-ball", "--engines", "euler", cwd=root)
    assert before.returncode == 2 and "engine 'euler'" in before.stderr  # not there before it is installed
    euler = root / "euler"
    euler.mkdir()
    (euler / "chatterbench_euler.py").write_text(readme_block("# chatterbench_euler.py", HOWTO))
    (euler / "pyproject.toml").write_text(readme_block("# pyproject.toml, beside it", HOWTO))
    pip_install(python, euler, EXAMPLE, cwd=root)  # one pip, two isolated builds (3 s of CPU each)
    write_installed(site_packages(python), "chatterbench_euler_wrong", euler_wrong(), "chatterbench-euler-wrong",
                    "euler_wrong = chatterbench_euler_wrong:EulerEngine", version="0.1.0")
    return python, root


@pytest.mark.slow
def test_an_engine_written_from_the_how_to_is_listed_checked_and_judged_match(venv):
    python, root = venv
    listed = cli(python, "engines", "euler", "pymunk", cwd=root)
    assert listed.returncode == 0, listed.stdout + listed.stderr
    rows = {ln.split()[0]: ln.split() for ln in listed.stdout.splitlines()[1:]}
    assert rows["euler"][1:4] == ["plugin", "chatterbench-euler", "0.1.0"] and rows["euler"][-1] == "ok"
    assert rows["pymunk"][-1] == "ok" and rows["pymunk"][-2][0].isdigit()  # pymunk's own version
    shown = cli(python, "compare", "--help", cwd=root)
    assert re.search(r"--engines .*\beuler\b", " ".join(shown.stdout.split())), shown.stdout  # listed with the others
    judged = cli(python, "compare", "bouncing-ball", "--engines", "euler", cwd=root)
    assert judged.returncode == 0, judged.stderr
    assert summary(judged, "euler", "verdict") == "match"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["euler", "pymunk"])
def test_the_shipped_contract_suite_passes_from_an_empty_folder(venv, engine):
    # as a plugin's author runs it: the installed package's pytest plugin, no file of this repository, an empty folder
    python, root = venv
    empty = root / f"empty-{engine}"
    empty.mkdir()
    done = _run(python, "-m", "pytest", "-v", "-p", "no:cacheprovider", "--chatterbench-engine", engine, cwd=empty)
    passed = re.search(r"\b(\d+) passed", done.stdout)
    assert done.returncode == 0 and passed and int(passed[1]) >= 15, done.stdout[-3000:] + done.stderr[-2000:]
    ran = [ln for ln in done.stdout.splitlines() if ln.startswith("chatterbench.engines.contract_tests::")]
    assert len(ran) == int(passed[1]) and all(f"[{engine}" in ln and "PASSED" in ln for ln in ran), done.stdout


@pytest.mark.slow
def test_the_readme_engine_with_a_wrong_restitution_is_not_match(venv):
    python, root = venv
    # known answer the other way: the plugin how-to's engine with every impact at 0.8 R, installed as its own plugin
    judged = cli(python, "compare", "bouncing-ball", "--engines", "euler_wrong", cwd=root)
    assert judged.returncode == 0, judged.stderr
    assert summary(judged, "euler_wrong", "verdict") != "match"


@pytest.mark.slow
def test_the_pymunk_example_is_match_and_early_with_a_rest_velocity(venv):
    python, root = venv
    judged = cli(python, "compare", "bouncing-ball", "--engines", "pymunk", "--dt", "1e-3", cwd=root)
    assert judged.returncode == 0 and summary(judged, "pymunk", "verdict") == "match", judged.stdout + judged.stderr
    # impacts slower than 0.5 m/s made plastic: the ball rests before the Zeno point (sticking 59 ms early, measured)
    early = cli(python, "compare", "bouncing-ball", "--engines", "pymunk", "--dt", "1e-3", "--set",
                "pymunk.rest_velocity=0.5", cwd=root)
    assert early.returncode == 0 and summary(early, "pymunk", "verdict") == "early", early.stdout + early.stderr
    assert float(summary(early, "pymunk", "stick_error_rel_max")) > 0.05  # beyond the 5 % tolerance
    # the facts of other adapters are not said of it: --export-model names the engines whose adapters export
    refused = cli(python, "run", "bouncing-ball", "--engines", "pymunk", "--export-model", root / "m.xml", cwd=root)
    assert refused.returncode == 2 and "engine 'pymunk': cannot export a model; engines that can: mujoco, pybullet" \
        in refused.stderr, refused.stderr
    # and it is drawn in a colour of its own, as every engine of the table is
    colours = _run(python, "-c", "from chatterbench.comparisons.outputs.style import engine_colour as c; "
                   "from chatterbench.engines.registry import ENGINE_NAMES as n; "
                   "print(c('pymunk'), *(c(e) for e in n if e != 'pymunk'))")
    mine, *others = colours.stdout.split()
    assert mine.startswith("#") and mine not in others, colours.stdout + colours.stderr
