"""symrl.__version__, symrl.provenance() and ``python -m symrl``."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import symrl
from symrl import about

ROOT = Path(symrl.__file__).resolve().parents[1]
KEYS = {
    "symrl",
    "torch",
    "torchrl",
    "tensordict",
    "gymnasium",
    "numpy",
    "python",
    "revision",
    "dirty",
    "editable",
}


def _env() -> dict[str, str]:
    """The environment for a child Python that imports this checkout's symrl."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    return env


def test_provenance_keys_and_types():
    info = symrl.provenance()
    assert set(info) == KEYS
    for key in ("torch", "torchrl", "tensordict", "gymnasium", "numpy", "python"):
        assert isinstance(info[key], str) and info[key][0].isdigit(), (key, info[key])
    assert info["python"] == ".".join(map(str, sys.version_info[:3]))
    assert info["symrl"] == symrl.__version__
    assert info["revision"] is None or isinstance(info["revision"], str)
    assert info["dirty"] in (None, True, False)
    assert info["editable"] in (None, True, False)
    json.dumps(info)  # goes into results files as is


def test_version_is_the_package_metadata():
    from importlib import metadata

    assert symrl.__version__ == metadata.version("symrl")


@pytest.mark.parametrize(
    ("version", "expected"),
    [
        ("0.1.dev3+g1a2b3c4", ("1a2b3c4", False)),
        ("0.1.dev3+g1a2b3c4.d20260102", ("1a2b3c4", True)),
        ("0.2.0+d20260102", (None, True)),
        ("0.2.0", (None, False)),
        ("0.1.0+local.build", (None, False)),
        (None, (None, None)),
    ],
)
def test_parse_revision(version, expected):
    assert about.parse_revision(version) == expected


def test_revision_comes_from_the_package_metadata(monkeypatch):
    real = about.package_version
    monkeypatch.setattr(
        about,
        "package_version",
        lambda name: "0.1.dev7+gfeedbee.d20260102" if name == "symrl" else real(name),
    )
    info = about.provenance()
    assert (info["symrl"], info["revision"], info["dirty"]) == (
        "0.1.dev7+gfeedbee.d20260102",
        "feedbee",
        True,
    )
    monkeypatch.setattr(
        about, "package_version", lambda name: "0.2.0" if name == "symrl" else real(name)
    )
    assert about.provenance()["revision"] is None


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git to make a foreign repository")
def test_revision_is_not_the_current_folders_repository(tmp_path):
    """Run from inside another git repository: provenance() must not
    report that repository's commit."""
    git = [
        "git",
        "-c",
        "user.name=t",
        "-c",
        "user.email=t@example.org",
        "-c",
        "commit.gpgsign=false",
    ]
    subprocess.run([*git, "init", "-q"], cwd=tmp_path, check=True)
    (tmp_path / "file.txt").write_text("another project\n")
    (tmp_path / "symrl").mkdir()  # a folder named like the package, dirty
    (tmp_path / "symrl" / "x.txt").write_text("untracked\n")
    subprocess.run([*git, "add", "file.txt"], cwd=tmp_path, check=True)
    subprocess.run([*git, "commit", "-q", "-m", "foreign"], cwd=tmp_path, check=True)
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=tmp_path, check=True, capture_output=True, text=True
    ).stdout.strip()
    script = "import json, symrl\nprint(json.dumps({'provenance': symrl.provenance()}))\n"
    out = subprocess.run(
        [sys.executable, "-c", script],
        cwd=tmp_path,
        env=_env(),
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    result = json.loads(out)
    here = json.loads(json.dumps(symrl.provenance()))
    # `editable` may differ: with the checkout on PYTHONPATH the child can find the checkout's
    # own *.egg-info (which has no direct_url.json) before the installed metadata.
    for key in KEYS - {"editable"}:
        assert result["provenance"][key] == here[key], key
    for prefix in (head, head[:7]):
        assert prefix not in out, (head, out)


def test_python_dash_m_symrl_is_the_cli():
    proc = subprocess.run(
        [sys.executable, "-m", "symrl", "--help"], env=_env(), capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("usage: symrl ")
    for command in ("drive", "train", "evaluate", "study", "plan"):
        assert command in proc.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "symrl", "no-such-command"],
        env=_env(),
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "invalid choice" in bad.stderr


def test_package_ships_typing_marker_and_license():
    assert (ROOT / "symrl" / "py.typed").is_file()
    if (ROOT / "pyproject.toml").is_file():  # a source checkout
        assert "MIT License" in (ROOT / "LICENSE").read_text()
