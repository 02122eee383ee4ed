"""The wheel carries exactly the project: built from a copy of the checkout with a
demo's run folder lying in it, it holds the two packages (``ogacq``, and ``drivers/``
as ``ogacq_drivers``), their data files and the LICENSE, nothing else; installed in a
fresh environment it runs the demo from any folder, writing where the README says."""

from __future__ import annotations

import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = {"ogacq": "ogacq", "ogacq_drivers": "drivers"}  # installed name -> folder


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: the tracked files are unknown")
    source = tmp_path_factory.mktemp("checkout")
    tracked = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard",
                              "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in filter(None, tracked.decode().split("\0")):
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    run_folder = source / "ogacq-demo-x"  # what a demo run in the checkout once left
    run_folder.mkdir()
    (run_folder / "__init__.py").write_text("")
    (run_folder / "session.jsonl").write_text("{}\n")
    dist = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "--no-index", "-q", "-w", str(dist), str(source)], check=True,
                   capture_output=True)
    return next(dist.glob("ogacq-*.whl"))


def test_the_wheel_holds_the_project_and_nothing_else(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    info = next(n.split("/")[0] for n in names if n.endswith(".dist-info/METADATA"))
    assert {n.split("/")[0] for n in names} == {"ogacq", "ogacq_drivers", info}
    top_level = zipfile.ZipFile(wheel).read(f"{info}/top_level.txt").decode().split()
    assert sorted(top_level) == ["ogacq", "ogacq_drivers"]
    assert f"{info}/licenses/LICENSE" in names
    assert "License-Expression: MIT" in zipfile.ZipFile(wheel).read(f"{info}/METADATA").decode()
    for data in ("ogacq/examples/machine.toml", "ogacq/examples/campaign.toml",
                 "ogacq/examples/paper/machine.toml", "ogacq/examples/paper/experiment2_12.csv",
                 "ogacq/report/templates/report.html.j2",
                 "ogacq_drivers/axes/profiles/cia402.toml"):
        assert data in names, data
    assert not [n for n in names if "tests/" in n or "ogacq-demo" in n]
    # every package of the checkout is in the wheel (the list in pyproject.toml is whole)
    for installed, folder in FOLDERS.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            relative = init.relative_to(ROOT / folder).as_posix()
            assert f"{installed}/{relative}" in names, relative


@pytest.mark.slow
def test_the_installed_wheel_runs_the_demo_from_any_folder(wheel, tmp_path):
    env = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(env)],
                   check=True, capture_output=True)
    python = env / "bin" / "python"
    # The test's own environment lends the dependencies (no network); its site folder
    # is added as a plain path, so its .pth files (an editable ogacq) are not run.
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; "
                                "print(sysconfig.get_path('purelib'))"], check=True,
                               capture_output=True, text=True).stdout.strip())
    (site / "test-dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index",
                    str(wheel)], check=True, capture_output=True)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(args, cwd=elsewhere, capture_output=True, text=True, timeout=120)

    where = run(str(python), "-c", "import ogacq, ogacq_drivers; "
                "print(ogacq.__file__); print(ogacq_drivers.__file__)")
    assert where.returncode == 0, where.stderr
    assert all(line.startswith(str(env)) for line in where.stdout.split()), where.stdout
    assert run(str(python), "-c", "import drivers").returncode != 0
    demo = run(str(env / "bin" / "ogacq"), "demo", "--speed", "200")
    assert demo.returncode == 0, demo.stderr
    assert [p.name for p in elsewhere.iterdir()] == ["ogacq-runs"]
    (folder,) = (elsewhere / "ogacq-runs").iterdir()
    assert folder.name.startswith("demo-")
    assert (folder / "report" / "report.html").is_file()
    assert not list(site.glob("ogacq-runs*")) and not list(site.glob("demo-*"))
