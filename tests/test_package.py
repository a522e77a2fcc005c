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
