"""A wheel built from the tree holds every package and subpackage, installs into a fresh
environment and its commands run from it.

An editable install (what ``pip install -e`` and the test suite use) finds modules in the
work tree whatever the packaging says, so a subpackage left out of ``[tool.setuptools]``
would only show in a built wheel. This builds one from a copy of the tracked files (as a
clean checkout has them: no build folder, no caches), installs it with ``--no-deps`` into a
new venv that borrows only the third-party packages of this interpreter (a path file, so no
download; the project's own editable install is not active there), and runs ``dsp-record``
and ``dsp-replay`` from that venv on a one-frame scene.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("dsp", "estimator", "recorder", "replay")
BIN = "Scripts" if os.name == "nt" else "bin"


def _tracked_files() -> list[str]:
    try:
        listed = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
            capture_output=True, text=True, check=True, timeout=60).stdout.splitlines()
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: the sources
        listed = [str(p.relative_to(ROOT)) for pkg in PACKAGES for p in (ROOT / pkg).rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts]
        listed += ["pyproject.toml", "README.md"]
    return [f for f in listed if (ROOT / f).is_file()]


def _env() -> dict[str, str]:
    """This environment without what would point Python at the work tree."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}


def _run(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    done = subprocess.run([str(a) for a in args], cwd=cwd, env=_env(), capture_output=True,
                          text=True, timeout=600, check=False)
    assert done.returncode == 0, f"{args}: {done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("setuptools", reason="building the wheel needs setuptools (test extra)")
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    for name in _tracked_files():
        if name.split("/")[0] in (*PACKAGES, "pyproject.toml", "README.md"):
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    _run(sys.executable, "-m", "pip", "wheel", src, "--no-deps", "--no-build-isolation",
         "--wheel-dir", tmp / "dist", "-q", cwd=tmp)
    (built,) = (tmp / "dist").glob("dual_sight-*.whl")
    return built


def _packages() -> Iterator[str]:
    for pkg in PACKAGES:
        for init in sorted((ROOT / pkg).rglob("__init__.py")):
            yield init.parent.relative_to(ROOT).as_posix()


def test_the_wheel_holds_every_package_module_and_marker(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    packages = list(_packages())
    assert {"replay/log", "replay/sinks/rerun", "estimator/tracking"} <= set(packages)
    assert [p for p in packages if f"{p}/__init__.py" not in names] == []
    modules = [p.relative_to(ROOT).as_posix() for pkg in PACKAGES
               for p in sorted((ROOT / pkg).rglob("*.py"))]
    assert [m for m in modules if m not in names] == []
    assert [p for p in PACKAGES if f"{p}/py.typed" not in names] == []
    assert not [n for n in names if n.split("/")[0] in ("tests", "scripts", "benchmarks")]
    # the real-ball detector's shared check and generic ball model travel with their
    # images' licence
    real = "estimator/detection/real/"
    assert {real + n for n in ("ball_check.onnx", "ball_generic.json", "NOTICE",
                               "LICENSE-images")} <= names
    assert not [n for n in names if n.split("/")[0] == "train"]


@pytest.fixture(scope="module")
def venv(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    env = tmp_path_factory.mktemp("venv") / "env"
    _run(sys.executable, "-m", "venv", "--without-pip", env, cwd=env.parent)
    python = env / BIN / "python"
    site = Path(_run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])",
                     cwd=env.parent).stdout.strip())
    ours = {sysconfig.get_paths()[k] for k in ("purelib", "platlib")}
    (site / "borrowed.pth").write_text("".join(f"{p}\n" for p in sorted(ours)))
    _run(sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index",
         "-q", wheel, cwd=env.parent)
    return env


def test_the_installed_project_is_the_wheel(venv: Path) -> None:
    site = _run(venv / BIN / "python", "-c", "import sysconfig; print(sysconfig.get_paths()"
                "['purelib'])", cwd=venv.parent).stdout.strip()
    code = ("import dsp, estimator.tracking, recorder, replay.log, replay.sinks.rerun, "
            "replay.evaluate\nprint(replay.__file__)\nprint(estimator.tracking.__file__)")
    for line in _run(venv / BIN / "python", "-c", code, cwd=venv.parent).stdout.splitlines():
        assert Path(line).resolve().is_relative_to(Path(site).resolve()), line
    version = _run(venv / BIN / "dsp-replay", "--version", cwd=venv.parent).stdout.strip()
    assert version.startswith("dsp-replay ") and version != "dsp-replay unknown"


def test_record_and_replay_run_from_the_wheel(venv: Path) -> None:
    work = venv.parent
    _run(venv / BIN / "dsp-record", work / "one.mcap", "--scenario", "scenario1", "--frames",
         "1", "--face-px", "256", "--renderer", "tiny", "-q", cwd=work)
    _run(venv / BIN / "dsp-replay", work / "one.mcap", "--out", work / "one.json", "-q",
         cwd=work)
    results = json.loads((work / "one.json").read_text(encoding="utf-8"))
    assert results["format"] == "dsp-replay-results"
    assert len(results["frames"]) == 3 and results["summary"]["fused_steps"] == 1
    for command in ("dsp-info", "dsp-eval", "dsp-calibrate"):
        assert _run(venv / BIN / command, "--version", cwd=work).stdout.startswith(command)
