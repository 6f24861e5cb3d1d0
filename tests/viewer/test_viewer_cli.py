"""``warp-hybrid view`` on the command line: bad flags, a real server, the host warning."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest
from conftest import ROOT, STILL

from warp_hybrid.cli import main
from warp_hybrid.viewer.serve import is_loopback, url_for


@pytest.mark.parametrize(
    "flags, problem",
    [
        (["--jpeg-quality", "0"], "--jpeg-quality must lie in 1..100"),
        (["--gaze", "fixed:0.5,0.5"], "view --gaze must be cursor"),
        (["--gaze", "laser"], "unknown kind 'laser'"),
        (["--spp", "4"], "--spp 4"),
        (["--fps", "-3"], "--fps must be a positive number"),
        (["--camera", "/World/Nope", "--size", "32x24"], "/World/Nope"),
        (["--port", "70000", "--size", "32x24"], "--port must lie in 0..65535"),
    ],
)
def test_a_bad_flag_is_one_error_line_and_status_2(flags: list[str], problem: str, capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    status = main(["view", str(STILL), "--record-dir", str(tmp_path), *flags])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and err[0].startswith("error: ") and problem in err[0], err


def test_loopback_hosts_and_urls() -> None:
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost") and is_loopback("127.8.0.1")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.4") and not is_loopback("example.org")
    assert url_for("::1", 8000) == "http://[::1]:8000/" and url_for("127.0.0.1", 80) == "http://127.0.0.1:80/"


def test_view_serves_the_page_until_interrupted(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    command = [sys.executable, "-m", "warp_hybrid", "view", str(STILL), "--port", "0", "--size", "32x24"]
    command += ["--threads", "1", "--record-dir", str(tmp_path)]
    process = subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()
        found = re.match(r"viewer: (http://127\.0\.0\.1:(\d+)/) \(Ctrl-C to stop\)", line)
        assert found and int(found.group(2)) > 0, line
        with urllib.request.urlopen(found.group(1), timeout=60) as response:
            assert response.status == 200 and b"viewer.js" in response.read()
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=120) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
