"""Device settings of fdem.init that are checked before Taichi is touched (the test process runs on the CPU)."""
import pytest

import taichi_fdem as fdem
from taichi_fdem import backend


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan")])
def test_device_memory_must_be_positive(bad):
    with pytest.raises(ValueError, match="device_memory_GB"):
        fdem.init(arch="cpu", device_memory_GB=bad)
    assert backend.arch() == "cpu"          # the test process's Taichi is untouched


def test_gpu_order_is_cuda_vulkan_metal():
    assert backend.GPU_ORDER == ("cuda", "vulkan", "metal")
