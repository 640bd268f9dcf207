"""The one build step pyproject.toml cannot say: the UI is built (Vite) before the package is,
so an installed runtime serves it. `make` builds it already; a plain `pip install .` builds
it here with npm, or stops with what to do."""

import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

UI = Path(__file__).resolve().parent / "webui" / "frontend"


class BuildWithUI(build_py):
    def run(self) -> None:
        # An editable install serves webui/frontend/dist from the source tree: make builds it.
        editable = getattr(self, "editable_mode", False)
        if not editable and not (UI / "dist" / "index.html").is_file():
            npm = shutil.which("npm")
            if npm is None:
                raise SystemExit(
                    "openpendant: the UI is not built and npm is not installed; "
                    "run `make ui` (or install Node.js and npm) before `pip install .`"
                )
            subprocess.run([npm, "ci", "--no-audit", "--no-fund"], cwd=UI, check=True)
            subprocess.run([npm, "run", "build"], cwd=UI, check=True)
        super().run()


setup(cmdclass={"build_py": BuildWithUI})
