"""The compiled-code cache of the auxiliary flow (netcosim.plants.casadi_tools.compile_functions).

A shared library is loaded only from a private cache directory and only if its sha256
matches the digest recorded when it was built; every failure falls back to the
uncompiled CasADi functions with one CompiledCodeWarning, giving the same numbers.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

import netcosim.controllers.planner.flow as aux_flow
import netcosim.plants.casadi_tools as ct
from netcosim.plants.flycrane.configurations import formation_2d

needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")


@pytest.fixture
def funs():
    return list(aux_flow._casadi_flow_functions(formation_2d()))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    d = tmp_path / "cache"
    monkeypatch.setenv("NETCOSIM_CACHE_DIR", str(d))
    monkeypatch.delenv("NETCOSIM_CACHE", raising=False)
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setattr(ct, "COMPILE", True)
    monkeypatch.setattr(ct, "_warned", False)
    return d


def _numbers(fs):
    """rhs and one DOP853 step of the flow of formation_2d at a fixed point."""
    s = formation_2d()
    q_r = s.q_nominal
    x = 0.05 * np.cos(np.arange(s.m))
    c = s.jacobian(q_r + x) @ x
    flow = aux_flow._CompiledFlow(fs).start(q_r, c)
    f0 = flow.rhs(0.5 * x)
    return np.concatenate([f0, *flow.step(0.5 * x, f0, 0.3)])


@needs_cc
def test_library_is_stored_with_its_digest_in_a_private_directory(cache, funs):
    out = ct.compile_functions(funs, "t")
    assert out is not funs
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    (lib,) = cache.glob("t_*.so")
    side = lib.with_name(lib.name + ".sha256")
    assert side.read_text().strip() == hashlib.sha256(lib.read_bytes()).hexdigest()
    np.testing.assert_allclose(_numbers(out), _numbers(funs), rtol=0, atol=1e-13)


@needs_cc
def test_a_tampered_library_is_rebuilt_not_loaded(cache, funs, monkeypatch):
    ct.compile_functions(funs, "t")
    (lib,) = cache.glob("t_*.so")
    good = lib.read_bytes()
    lib.write_bytes(good[:-64] + b"\0" * 64)          # someone changed the library
    loaded = []
    real_external = ct.ca.external

    def spy(name, path):
        loaded.append(hashlib.sha256(Path(path).read_bytes()).hexdigest())
        return real_external(name, path)

    monkeypatch.setattr(ct.ca, "external", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = ct.compile_functions(funs, "t")
    assert out is not funs
    digest = hashlib.sha256(lib.read_bytes()).hexdigest()
    assert loaded == [digest, digest]                 # only the rebuilt, verified library was loaded
    assert digest != hashlib.sha256(good[:-64] + b"\0" * 64).hexdigest()
    np.testing.assert_allclose(_numbers(out), _numbers(funs), rtol=0, atol=1e-13)


def test_a_world_writable_cache_directory_is_refused_with_a_warning(cache, funs):
    cache.mkdir()
    os.chmod(cache, 0o777)
    with pytest.warns(ct.CompiledCodeWarning, match="writable by group or others") as rec:
        assert ct.compile_functions(funs, "t") is funs
    assert str(cache) in str(rec[0].message)
    assert list(cache.iterdir()) == []


def test_a_missing_compiler_falls_back_once_with_the_same_numbers(cache, funs, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    with pytest.warns(ct.CompiledCodeWarning, match="'/nonexistent/cc' not found") as rec:
        a = ct.compile_functions(funs, "t")
        b = ct.compile_functions(funs, "t")                    # second fallback: no second warning
    assert a is funs and b is funs and len(rec) == 1
    assert _numbers(a).tolist() == _numbers(funs).tolist()


def test_a_failing_build_falls_back_with_one_warning(cache, funs, monkeypatch):
    def fail(cmd, **kw):
        raise subprocess.CalledProcessError(1, cmd, stderr=b"cc1: fatal error: out of memory")

    monkeypatch.setattr(ct.subprocess, "run", fail)
    monkeypatch.setattr(ct.shutil, "which", lambda name: "/usr/bin/cc")
    with pytest.warns(ct.CompiledCodeWarning, match="exit status 1: cc1: fatal error") as rec:
        assert ct.compile_functions(funs, "t") is funs
    assert len(rec) == 1 and list(cache.glob("*.so")) == []


def test_cache_location(monkeypatch, tmp_path):
    monkeypatch.delenv("NETCOSIM_CACHE_DIR", raising=False)
    monkeypatch.delenv("NETCOSIM_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert ct.cache_dir() == str(tmp_path / "netcosim")
    monkeypatch.setenv("NETCOSIM_CACHE_DIR", str(tmp_path / "mine"))
    assert ct.cache_dir() == str(tmp_path / "mine")
