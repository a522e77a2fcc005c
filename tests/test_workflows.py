"""The files that run the course elsewhere: the GitHub Actions workflow a fork runs, and
the conda environment Binder builds. Neither service can be reached from the test suite,
so these tests check what can be checked here: the structure, that both install what
pyproject.toml names (torch as a CPU build), and the workflow through two linters
(GitHub's schema, and actionlint's checks where its wheel exists), which must also catch a
broken copy of it."""
import platform
import re
import subprocess
import sys
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
    # a spec limited to some platforms (after ';') is left out: conda cannot install it everywhere
    return dict(re.fullmatch(r"([a-z-]+)>=([\d.]+)", spec).groups() for spec in specs if ";" not in spec)


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


BROKEN = [
    # (what is wrong, the change to the workflow)
    ("a job without runs-on", ("    runs-on: ubuntu-latest\n    timeout-minutes: 60\n", "    timeout-minutes: 60\n")),
    ("an unknown key in a step", ("      - uses: actions/checkout@v4\n", "      - uses: actions/checkout@v4\n        wiht:\n          depth: 1\n")),
    ("an expression that reads a context that is not there",
     ("run: make test TORCH=torch==", "run: make test ${{ matrix.cpu }} TORCH=torch==")),
]


def lint(tool: list[str], path: Path) -> subprocess.CompletedProcess:
    return subprocess.run(tool + [str(path)], capture_output=True, text=True, timeout=120)


def linters() -> list[tuple[str, list[str]]]:
    """The linters installed beside this Python: check-jsonschema with GitHub's workflow
    schema (every platform) and, where its wheel exists (Linux x86-64), jactionlint with
    actionlint's checks (expressions, contexts, job needs), no shellcheck."""
    bin_dir = Path(sys.executable).parent
    found = [("check-jsonschema", [str(bin_dir / "check-jsonschema"), "--builtin-schema", "vendor.github-workflows"])]
    if (bin_dir / "jactionlint").exists():
        found.append(("jactionlint", [str(bin_dir / "jactionlint"), "--profile", "correctness", "--shellcheck="]))
    return found


def test_the_linters_are_installed_where_pyproject_says():
    names = [name for name, _ in linters()]
    assert "check-jsonschema" in names
    if sys.platform == "linux" and platform.machine() == "x86_64":
        assert "jactionlint" in names


@pytest.mark.parametrize("name, tool", linters(), ids=[name for name, _ in linters()])
def test_the_workflow_passes_its_linters(name, tool):
    result = lint(tool, WORKFLOW)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.slow
@pytest.mark.parametrize("what, change", BROKEN, ids=[what for what, _ in BROKEN])
def test_a_broken_workflow_fails_the_lint(tmp_path, what, change):
    """Each break is caught by at least one linter, so a broken workflow fails make test."""
    old, new = change
    text = WORKFLOW.read_text()
    assert old in text, what
    broken = tmp_path / ".github" / "workflows" / "notebooks.yml"
    broken.parent.mkdir(parents=True)
    broken.write_text(text.replace(old, new, 1))
    # the fastest first (jactionlint, a Go binary, where it is installed); any one failing will do
    results = {}
    for name, tool in reversed(linters()):
        results[name] = lint(tool, broken).returncode
        if results[name] != 0:
            break
    assert any(code != 0 for code in results.values()), (what, results)


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


def test_the_laptop_cpu_job_and_ci_run_the_capped_tests():
    job = workflow()["jobs"]["laptop-cpu"]
    assert re.search(r"^make test-laptop TORCH=torch==[\d.]+\+cpu$", run_lines(job), re.M)
    makefile = (ROOT / "Makefile").read_text()
    assert re.search(r"^LAPTOP_CPU = ONEDNN_MAX_CPU_ISA=AVX2 ATEN_CPU_CAPABILITY=avx2$", makefile, re.M)
    assert re.search(r"^\t\$\(LAPTOP_CPU\) \$\(BIN\)/python -m pytest \$\(CPU_TESTS\)", makefile, re.M)
    ci = (ROOT / ".ci" / "run").read_text()
    assert re.search(r"^make test$", ci, re.M) and re.search(r"^make test-laptop$", ci, re.M)
