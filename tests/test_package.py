import subprocess
import sys


def test_import_is_light():
    """`import motionlab` must stay instant: no torch, matplotlib or numpy until a module is used."""
    code = ("import sys, motionlab; heavy = [m for m in ('torch', 'matplotlib', 'numpy') if m in sys.modules];"
            "print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == ""


def test_modules_load_on_first_use():
    import motionlab
    assert motionlab.skeleton.LOCOMOTION.n_joints == 21
    assert "training" in dir(motionlab)


def test_every_module_is_listed_and_loads_by_its_name():
    from pathlib import Path

    import motionlab
    package = Path(motionlab.__file__).parent
    modules = {p.stem for p in package.glob("*.py") if p.stem != "__init__"} | \
              {p.parent.name for p in package.glob("*/__init__.py")}
    assert set(motionlab.__all__) == modules
    for name in motionlab.__all__:
        assert getattr(motionlab, name).__name__ == f"motionlab.{name}"
