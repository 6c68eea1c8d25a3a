"""Start-up: ``fdem.init`` starts Taichi through its public API only, with the offline kernel
cache on, and the settings of 0.1.0 that changed Taichi's front end are accepted with a
DeprecationWarning and change nothing."""
import platform
import warnings

import pytest
import taichi as ti

import taichi_fdem as fdem
from taichi_fdem import backend


def test_offline_cache_is_on_by_default():
    """The conftest's ``fdem.init`` (the defaults) keeps compiled kernels on disk: a later
    process starts from them."""
    backend.ensure_init()
    assert ti.cfg.offline_cache is True
    assert ti.cfg.cfg_optimization is False


def test_front_end_shortcuts_is_deprecated_and_changes_nothing():
    backend.ensure_init()
    before = dict(backend._state)
    with pytest.warns(DeprecationWarning, match="front_end_shortcuts"):
        fdem.init(arch=before["arch"], precision=before["precision"], front_end_shortcuts=False)
    assert backend.generation() == before["generation"]          # same settings: not re-initialised
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fdem.init(arch=before["arch"], precision=before["precision"])


def test_taichi_header_from_public_values():
    line = backend.taichi_header()
    assert line.startswith("[Taichi] version " + ".".join(map(str, ti.__version__)) + ",")
    assert line.endswith("python " + platform.python_version())
