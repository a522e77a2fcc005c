"""What this machine's PyTorch can do on the CPU, asked of PyTorch and oneDNN themselves.

PyTorch's CPU kernels come in two families, and each can be capped below what the
processor has, which is how a developer on a large server tests what a laptop will do::

    ONEDNN_MAX_CPU_ISA=AVX2 ATEN_CPU_CAPABILITY=avx2 python -m pytest ...

* **oneDNN** (``torch.backends.mkldnn``) runs the LSTM, convolutions and large products.
  It picks an instruction set at start-up (``ONEDNN_MAX_CPU_ISA`` caps it) and builds a
  bfloat16 or float16 kernel only where that set has one: on an AVX2 CPU (most laptops and
  GitHub's runners) ``nn.LSTM`` under bfloat16 autocast raises "could not create a
  primitive descriptor". :func:`onednn_isa` reads the set it chose from oneDNN's own
  report, and :func:`onednn_lstm` tries the LSTM in a dtype once.
* **ATen's own kernels** (element-wise work, PyTorch's own products) are compiled for
  several instruction sets and choose one at start-up (``ATEN_CPU_CAPABILITY`` caps it):
  ``torch.backends.cpu.get_cpu_capability()``.

Nothing here reads the processor's flags: a capped oneDNN on an AMX server answers as a
laptop does, so the library's kernel choices and the tests' guards follow the kernels
that will really run. Each answer is computed once per process.
"""
from __future__ import annotations

import ctypes
import functools
import os
import subprocess
import sys
import tempfile
from contextlib import contextmanager

import torch
from torch import nn

_ISA_PREFIX = "onednn_verbose,v1,info,cpu,isa:"


def _isa_line(report: str) -> str | None:
    """The instruction set named in a oneDNN verbose report, or ``None`` if it names none."""
    for line in report.splitlines():
        if line.startswith(_ISA_PREFIX):
            return line[len(_ISA_PREFIX):].strip()
    return None


def _run_one_primitive() -> None:
    """Run one small LSTM through oneDNN (its float32 LSTM exists on every x86-64 CPU)."""
    with torch.no_grad(), _onednn(True):
        nn.LSTM(2, 2)(torch.zeros(3, 1, 2))


def _report_in_this_process() -> str:
    """oneDNN's verbose report while it runs one primitive, read from this process's
    standard output (file descriptor 1, where oneDNN prints)."""
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    saved = os.dup(1)
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 1)
        try:
            with torch.backends.mkldnn.verbose(torch.backends.mkldnn.VERBOSE_ON):
                _run_one_primitive()
        finally:
            libc.fflush(None)
            os.dup2(saved, 1)
            os.close(saved)
        captured.seek(0)
        return captured.read().decode("utf-8", errors="replace")


_PROBE = "import motionlab.cpu as c; c._run_one_primitive()"


def _report_in_a_new_process() -> str:
    """The same report from a fresh Python, with this process's environment (its caps):
    oneDNN prints its instruction set only once per process, so a process that has shown
    verbose output before cannot show it again."""
    env = dict(os.environ, ONEDNN_VERBOSE="1")
    result = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=120)
    return result.stdout


@functools.cache
def onednn_isa() -> str:
    """The instruction set oneDNN's kernels use in this process, in oneDNN's words
    (``"Intel AVX2"``, ``"Intel AVX-512 with Intel DL Boost and bfloat16 support"``, ...):
    the processor's, capped by ``ONEDNN_MAX_CPU_ISA``. ``""`` when PyTorch has no oneDNN
    (or it would not say)."""
    if not torch.backends.mkldnn.is_available():
        return ""
    try:
        isa = _isa_line(_report_in_this_process())
    except (OSError, TypeError, AttributeError):     # no file descriptor 1 to borrow, no C library by name
        isa = None
    if isa is None:
        isa = _isa_line(_report_in_a_new_process())
    return isa or ""


def native_bfloat16() -> bool:
    """Whether oneDNN multiplies bfloat16 matrices with the processor's own bfloat16
    instructions here (AVX512-BF16, AMX, AVX-NE-CONVERT), as its instruction set says
    (:func:`onednn_isa`). Without them bfloat16 products are emulated, slower than float32,
    and where oneDNN has no bfloat16 kernel at all (AVX2) PyTorch uses its own."""
    return "bfloat16" in onednn_isa()


@functools.cache
def onednn_lstm(dtype: torch.dtype) -> bool:
    """Whether ``nn.LSTM`` runs under CPU autocast to ``dtype`` here with oneDNN enabled
    (``True`` for float32, and wherever PyTorch would not hand it to oneDNN). Tried once on
    a tiny LSTM, for inference (no gradients) and for training (a different oneDNN
    primitive): oneDNN builds its bfloat16 LSTM from AVX-512 on (not on AVX2), its float16
    one on fewer CPUs still, and on some (Intel's AMX with AVX512-FP16) the float16 one for
    inference only."""
    if dtype == torch.float32 or not torch.backends.mkldnn.is_available():
        return True
    for gradients in (False, True):
        try:
            with torch.set_grad_enabled(gradients), _onednn(True), torch.autocast("cpu", dtype=dtype):
                nn.LSTM(2, 2)(torch.zeros(3, 1, 2))
        except RuntimeError:
            return False
    return True


def aten_capability() -> str:
    """The instruction set ATen's own CPU kernels were chosen for (``"AVX2"``,
    ``"AVX512"``, ``"DEFAULT"``, ...), capped by ``ATEN_CPU_CAPABILITY``."""
    return torch.backends.cpu.get_cpu_capability()


def summary() -> str:
    """One line for benchmark tables and bug reports: both kernel families' choices."""
    bf16 = "native" if native_bfloat16() else "emulated"
    lstm = "" if onednn_lstm(torch.bfloat16) else ", no bfloat16 LSTM"
    return (f"oneDNN: {onednn_isa() or 'absent'} (bfloat16 products: {bf16}{lstm}); "
            f"ATen kernels: {aten_capability()}")


@contextmanager
def _onednn(enabled: bool):
    """oneDNN on or off for PyTorch's CPU operations inside the block, restored on leaving."""
    before = torch.backends.mkldnn.enabled
    torch.backends.mkldnn.enabled = enabled
    try:
        yield
    finally:
        torch.backends.mkldnn.enabled = before


def onednn_disabled():
    """A block in which PyTorch's CPU operations do not call oneDNN (``torch.backends.mkldnn``)
    and use PyTorch's own kernels. A process-wide setting, restored on leaving: do not use
    it while other threads compute."""
    return _onednn(False)
