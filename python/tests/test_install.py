"""`pip install ./python` works offline (no PyPI: --no-build-isolation --no-index, Debian's
setuptools) into a fresh virtual environment, and installs the package with py.typed and the
version of the contract."""

import os
import shutil
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

from tests.support import ROOT


class InstallTest(unittest.TestCase):
    def test_pip_installs_the_package_into_a_venv(self):
        tmp = Path(tempfile.mkdtemp(prefix="fragsim-pyinstall-"))
        self.addCleanup(shutil.rmtree, tmp, ignore_errors=True)
        # a copy: setuptools writes build/ and *.egg-info beside the sources
        src = tmp / "src"
        shutil.copytree(ROOT / "python", src,
                        ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
        venv = tmp / "venv"
        subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip",
                        str(venv)], check=True, timeout=60)
        py = venv / "bin" / "python"
        r = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q",
                            "--no-build-isolation", "--no-index", str(src)],
                           capture_output=True, text=True, timeout=120)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        probe = ("import fragsim, fragsim.results, os, json; d = os.path.dirname(fragsim.__file__);"
                 "print(json.dumps([d, fragsim.__version__, os.path.exists(d + '/py.typed')]))")
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # not the source tree
        out = subprocess.run([str(py), "-c", probe], cwd=tmp, env=env, capture_output=True,
                             text=True, check=True, timeout=60).stdout
        where, version, typed = __import__("json").loads(out)
        self.assertTrue(where.startswith(str(venv)), where)
        self.assertEqual(version, (ROOT / "python" / "fragsim" / "_version.py").read_text()
                         .split('__version__ = "')[1].split('"')[0])
        self.assertTrue(typed)


if __name__ == "__main__":
    unittest.main()
