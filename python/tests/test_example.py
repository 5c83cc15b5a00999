"""The README's example runs headless and writes its picture."""

import os
import re
import subprocess
import sys

from conftest import ROOT


def test_the_example_writes_its_image(tmp_path):
    out = tmp_path / "sphere.png"
    script = os.path.join(ROOT, "python", "examples", "sphere.py")
    run = subprocess.run([sys.executable, script, str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {out}" in run.stdout
    # The ball is tinted orange: more red than green than blue at the centre of the picture.
    r, g, b = (int(v) for v in re.search(r"centre pixel \((\d+), (\d+), (\d+)", run.stdout).groups())
    assert r > g > b, run.stdout
