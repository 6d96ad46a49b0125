"""Every compiled kernel takes its fastmath flags from one constant,
`contact_bench.core.config.FASTMATH`, or uses no fastmath at all (as stumpy's test of
`config.STUMPY_FASTMATH_FLAGS`): a kernel cannot drift to other flags unseen."""

from __future__ import annotations

import importlib
import pkgutil

import pytest
from numba.core.registry import CPUDispatcher

import contact_bench
from contact_bench.core.config import FASTMATH

#: the subpackages that hold compiled functions
PACKAGES = ("core", "kernels", "exact", "schemes", "cases")


def _dispatchers() -> list[tuple[str, CPUDispatcher]]:
    out = []
    for sub in PACKAGES:
        package = importlib.import_module(f"{contact_bench.__name__}.{sub}")
        for info in pkgutil.iter_modules(package.__path__, f"{package.__name__}."):
            module = importlib.import_module(info.name)
            for name, obj in vars(module).items():
                if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == info.name:
                    out.append((f"{info.name}.{name}", obj))
    return out


KERNELS = _dispatchers()


def test_the_kernels_are_found() -> None:
    names = {name.rsplit(".", 1)[-1] for name, _ in KERNELS}
    assert {"blown_up", "tf_spike_kernel", "implicit_kernel", "cd_stencil"} <= names


@pytest.mark.parametrize("name, kernel", KERNELS, ids=[name for name, _ in KERNELS])
def test_a_kernel_uses_the_one_fastmath_constant_or_none(name: str, kernel) -> None:
    flags = kernel.targetoptions.get("fastmath", False)
    assert flags is False or flags is FASTMATH, f"{name}: fastmath={flags!r}, not FASTMATH"
