"""motionlab.cpu: what PyTorch and oneDNN can do here, asked of them, and the laptop cap
(ONEDNN_MAX_CPU_ISA=AVX2, ATEN_CPU_CAPABILITY=avx2) that reproduces an AVX2 laptop on any
x86-64 CPU."""
import json
import os
import platform
import subprocess
import sys

import pytest
import torch

from motionlab import cpu

x86 = pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"), reason="the caps are x86-64's")
onednn = pytest.mark.skipif(not torch.backends.mkldnn.is_available(), reason="PyTorch without oneDNN")

_REPORT = """
import json, torch
from motionlab import cpu
from motionlab.models.moglow import MoGlow, MoGlowConfig
stream = MoGlow(MoGlowConfig(steps=2, hidden=8)).stream(torch.zeros(1, 10, 66), weights=torch.bfloat16)
print(json.dumps({"isa": cpu.onednn_isa(), "native": cpu.native_bfloat16(), "aten": cpu.aten_capability(),
                  "bf16_lstm": cpu.onednn_lstm(torch.bfloat16), "kernel": stream._kernel}))
"""


def report(**caps) -> dict:
    """What motionlab.cpu and one bfloat16 MoGlow stream say in a fresh process with ``caps``
    in its environment (the caps are read when PyTorch starts)."""
    env = {k: v for k, v in os.environ.items() if k not in ("ONEDNN_MAX_CPU_ISA", "ATEN_CPU_CAPABILITY")}
    result = subprocess.run([sys.executable, "-c", _REPORT], env=env | caps, capture_output=True, text=True,
                            timeout=300, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_the_isa_line_is_read_from_onednns_report():
    text = ("onednn_verbose,v1,info,oneDNN v3.12.0 (commit 80afa71)\n"
            "onednn_verbose,v1,info,cpu,runtime:OpenMP,nthr:2\n"
            "onednn_verbose,v1,info,cpu,isa:Intel AVX-512 with Intel DL Boost and bfloat16 support\n")
    assert cpu._isa_line(text) == "Intel AVX-512 with Intel DL Boost and bfloat16 support"
    assert cpu._isa_line("onednn_verbose,v1,info,cpu,runtime:OpenMP,nthr:2\n") is None


@x86
@onednn
def test_this_process_agrees_with_itself():
    isa = cpu.onednn_isa()
    assert isa.startswith("Intel ")
    if cpu.native_bfloat16():                     # native bfloat16 kernels imply a bfloat16 LSTM
        assert cpu.onednn_lstm(torch.bfloat16)
    if isa in ("Intel AVX2", "Intel SSE4.1", "Intel AVX"):   # no bfloat16 kernels below AVX-512
        assert not cpu.onednn_lstm(torch.bfloat16) and not cpu.native_bfloat16()
    assert cpu.onednn_lstm(torch.float32)
    line = cpu.summary()
    assert isa in line and cpu.aten_capability() in line


@pytest.mark.slow
@x86
@onednn
def test_the_answers_follow_the_capped_onednn_not_the_processor():
    # SSE4.1 is below every x86-64 CPU PyTorch runs on: only a reading of oneDNN can say it
    capped = report(ONEDNN_MAX_CPU_ISA="SSE41", ATEN_CPU_CAPABILITY="default")
    assert capped["isa"] == "Intel SSE4.1" and capped["aten"] == "DEFAULT"
    assert not capped["native"] and not capped["bf16_lstm"]


@pytest.mark.slow
@x86
@onednn
def test_the_laptop_cap_reproduces_an_avx2_laptop_on_any_cpu():
    """Under the cap CI runs its second pass with, oneDNN has no bfloat16 LSTM (the failure
    an AVX2 laptop meets), no native bfloat16, and one bfloat16 stream takes the laptop's
    matrix-vector kernel, whatever processor runs the tests."""
    laptop = report(ONEDNN_MAX_CPU_ISA="AVX2", ATEN_CPU_CAPABILITY="avx2")
    assert laptop["isa"] in ("Intel AVX2", "Intel AVX", "Intel SSE4.1")     # at most AVX2
    assert laptop["aten"] in ("AVX2", "DEFAULT")
    assert not laptop["native"] and not laptop["bf16_lstm"]
    assert laptop["kernel"] == "matrix-vector"


def test_onednn_disabled_restores_the_setting_when_the_block_raises():
    before = torch.backends.mkldnn.enabled
    with pytest.raises(RuntimeError):
        with cpu.onednn_disabled():
            assert not torch.backends.mkldnn.enabled
            raise RuntimeError("inside")
    assert torch.backends.mkldnn.enabled == before
