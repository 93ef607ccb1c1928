"""estimator/ is pure: importing it (or any submodule) pulls in no mcap, rerun or pybullet, and
its source imports nothing but the standard library, numpy, OpenCV and itself.

Every module is found by walking the package, so a new room or module is checked without
being listed here.
"""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import estimator

FORBIDDEN = ("mcap", "rerun", "pybullet", "mcap_ros2", "rosbags")
ALLOWED = {"numpy", "cv2", "estimator"} | set(sys.stdlib_module_names)
PACKAGE = Path(estimator.__file__).parent


def _modules() -> list[str]:
    found = ["estimator"]
    found += sorted(m.name for m in pkgutil.walk_packages(estimator.__path__, "estimator."))
    return found


def test_the_walk_finds_every_room() -> None:
    modules = _modules()
    for room in ("estimator.detection", "estimator.calibration", "estimator.tracking"):
        assert room in modules and any(m.startswith(room + ".") for m in modules), room
    on_disk = {p for p in PACKAGE.rglob("*.py")}
    assert len(on_disk) == len(modules), "a module the walk does not reach (no __init__.py?)"


def test_import_is_pure() -> None:
    code = (
        f"import sys, importlib\nfor m in {_modules()!r}: importlib.import_module(m)\n"
        f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})\n"
        "print(','.join(bad))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert result.stdout.strip() == ""


def test_source_imports_only_numpy_opencv_and_the_standard_library() -> None:
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            bad += [f"{path.relative_to(PACKAGE.parent)}:{node.lineno} imports {n}"
                    for n in names if n.split(".")[0] not in ALLOWED]
    assert bad == []
