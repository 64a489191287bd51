"""Test support: a real fragsimd on a free loopback port, the fragsim CLI, paths.

The binaries come from the environment (ctest sets FRAGSIMD and FRAGSIM_CLI, tests/CMakeLists.txt),
else from the source tree's build/. The daemon runs with a temporary data directory and token
file; it is killed at the end (addModuleCleanup), and, should this Python process die first
(a ctest time-out), by the kernel (PR_SET_PDEATHSIG).
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path
from typing import List, Optional

ROOT = Path(__file__).resolve().parents[2]
FRAGSIMD = os.environ.get("FRAGSIMD") or str(ROOT / "build" / "server" / "fragsimd")
FRAGSIM_CLI = os.environ.get("FRAGSIM_CLI") or str(ROOT / "build" / "cli" / "fragsim")
MINIMAL = ROOT / "examples" / "minimal" / "scenario.json"
TOKEN = "python-test-token-0123456789"


def _die_with_parent() -> None:
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


class Daemon:
    """fragsimd in a temporary directory; ``url`` once started."""

    def __init__(self, extra: Optional[List[str]] = None) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="fragsim-pytest-"))
        self.extra = extra or []
        self.proc: Optional[subprocess.Popen] = None
        self.url = ""
        (self.dir / "tokens").write_text(f"# test tokens\n{TOKEN}\n")

    def start(self, timeout_s: float = 30.0) -> "Daemon":
        argv = [FRAGSIMD, "--listen", "127.0.0.1:0", "--data-dir", str(self.dir / "data"),
                "--token-file", str(self.dir / "tokens"), "--port-file", str(self.dir / "port"),
                "--threads", "2", "--log-level", "debug"] + self.extra
        self.log = open(self.dir / "fragsimd.log", "wb")
        self.proc = subprocess.Popen(argv, stdout=self.log, stderr=self.log,
                                     preexec_fn=_die_with_parent)
        deadline = time.monotonic() + timeout_s
        port_file = self.dir / "port"
        while time.monotonic() < deadline:
            if port_file.exists() and port_file.read_text().strip():
                self.url = f"http://127.0.0.1:{int(port_file.read_text())}"
                return self
            if self.proc.poll() is not None:
                raise RuntimeError(f"fragsimd exited at start ({self.proc.returncode}):\n"
                                   + self.log_text())
            time.sleep(0.02)
        self.stop()
        raise RuntimeError("fragsimd wrote no port file in time:\n" + self.log_text())

    def log_text(self) -> str:
        return (self.dir / "fragsimd.log").read_text(errors="replace")

    def stop(self) -> None:
        """Kills the daemon (SIGKILL: nothing of it is tested here) and removes its files."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=10)
        self.proc = None
        if hasattr(self, "log"):
            self.log.close()
        if os.environ.get("KEEP_TMP") != "1":
            shutil.rmtree(self.dir, ignore_errors=True)


def cli_run(scenario: Path, out: Path) -> None:
    """``fragsim run SCENARIO --out OUT`` (must succeed)."""
    r = subprocess.run([FRAGSIM_CLI, "run", str(scenario), "--out", str(out), "--quiet"],
                       capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        raise RuntimeError(f"fragsim run failed ({r.returncode}): {r.stderr}")
