"""Numeric evaluation and compilation of CasADi Functions, shared by ``plants/`` and ``controllers/``.

* :class:`BufferedFunction` -- numpy-in/numpy-out call of a Function through CasADi's
  buffer interface (``Function.buffer()``): calling a ``casadi.Function`` the plain way
  converts every argument to ``DM`` and back, which costs tens of microseconds, more
  than evaluating the plant equations;
* :class:`FunctionBuffers` -- the same interface one level lower: the preallocated
  argument and result arrays themselves, for inner loops that fill and read them in place;
* :func:`compile_functions` -- Functions compiled to a shared library with the C compiler
  (``$CC``, default ``cc``), cached on disk in :func:`cache_dir`.  Any failure (no
  compiler, a build error, an unsafe cache directory, CasADi unable to load the result)
  issues one :class:`CompiledCodeWarning` per process and returns the uncompiled
  Functions: the same numbers, slower.

Nothing here imports ``netcosim``, ``controllers`` or ``experiments``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import tempfile
import warnings

import casadi as ca
import numpy as np

__all__ = ["BufferedFunction", "FunctionBuffers", "CompiledCodeWarning", "compile_functions", "cache_dir",
           "COMPILE"]

#: Whether :func:`compile_functions` compiles at all; ``False`` returns the Functions
#: unchanged, silently (they then run in CasADi's virtual machine).  Read at every call.
COMPILE = True


class BufferedFunction:
    """``BufferedFunction(f)(*args) -> [numpy arrays]``: evaluate *f* numerically.

    Inputs must be dense (any array-like of the right size, copied in); outputs are
    returned as fresh arrays: shape ``(k,)`` for column vectors, ``(rows, cols)``
    otherwise, with sparse outputs scattered into dense zeros.  ``fun``: the CasADi
    ``Function`` (every input dense).
    """

    def __init__(self, fun: ca.Function):
        self.fun = fun
        self._in = []
        for i in range(fun.n_in()):
            sp = fun.sparsity_in(i)
            if not sp.is_dense():
                raise ValueError(f"{fun.name()}: input {i} must be dense")
            self._in.append(np.zeros(sp.nnz()))
        self._out, self._shape, self._scatter = [], [], []
        for i in range(fun.n_out()):
            sp = fun.sparsity_out(i)
            self._out.append(np.zeros(sp.nnz()))
            shape = (sp.size1(),) if sp.size2() == 1 else (sp.size1(), sp.size2())
            self._shape.append(shape)
            if sp.is_dense():
                self._scatter.append(None)
            else:
                r, c = sp.get_triplet()
                self._scatter.append((np.asarray(r, dtype=int), np.asarray(c, dtype=int)))
        self._buf, self._eval = fun.buffer()
        for i, a in enumerate(self._in):
            self._buf.set_arg(i, memoryview(a))
        for i, a in enumerate(self._out):
            self._buf.set_res(i, memoryview(a))

    def __call__(self, *args):
        if len(args) != len(self._in):
            raise TypeError(f"{self.fun.name()} takes {len(self._in)} arguments, got {len(args)}")
        for dst, a in zip(self._in, args):
            if type(a) is np.ndarray and a.ndim > 1:  # matrices column-major; vectors, lists, floats as they are
                a = a.ravel(order="F")
            elif type(a) is not np.ndarray and type(a) is not float and np.ndim(a) > 1:
                a = np.ravel(a, order="F")
            dst[:] = a
        self._eval()
        res = []
        for nz, shape, sc in zip(self._out, self._shape, self._scatter):
            if sc is None:
                res.append(nz.copy() if len(shape) == 1 else nz.reshape(shape, order="F").copy())
            else:
                d = np.zeros(shape if len(shape) == 2 else (shape[0], 1))
                d[sc[0], sc[1]] = nz
                res.append(d if len(shape) == 2 else d[:, 0])
        return res


class FunctionBuffers:
    """Preallocated arrays of a Function with dense outputs: fill ``args[i][:]``, call
    ``eval()``, read ``res[j]`` (the nonzeros, column-major; overwritten by the next call).
    ``fun``: the CasADi ``Function`` (every output dense)."""

    def __init__(self, fun: ca.Function):
        self.args = [np.zeros(fun.nnz_in(i)) for i in range(fun.n_in())]
        self.res = [np.zeros(fun.nnz_out(i)) for i in range(fun.n_out())]
        for i in range(fun.n_out()):
            if not fun.sparsity_out(i).is_dense():
                raise ValueError(f"{fun.name()}: output {i} must be dense")
        self._buf, self.eval = fun.buffer()
        for i, a in enumerate(self.args):
            self._buf.set_arg(i, memoryview(a))
        for i, a in enumerate(self.res):
            self._buf.set_res(i, memoryview(a))


class CompiledCodeWarning(UserWarning):
    """CasADi Functions could not be compiled or loaded (no C compiler, a build error, an
    unsafe cache directory); the same Functions run uncompiled instead: the same numbers,
    slower (about 6x for the auxiliary flow of the planners).  Issued once per process."""


_warned = False


def warn_uncompiled(reason: str, stacklevel: int = 3) -> None:
    """Issue the process's one :class:`CompiledCodeWarning`, naming *reason*; *stacklevel*: the
    frame the warning points to, 1 being this function's caller (as :func:`warnings.warn`
    counts from its own caller)."""
    global _warned
    if not _warned:
        _warned = True
        warnings.warn(f"netcosim: compiled CasADi code unavailable, running it uncompiled (same results, slower): "
                      f"{reason}", CompiledCodeWarning, stacklevel=stacklevel + 1)


def cache_dir() -> str:
    """Directory of the compiled-code cache: ``$NETCOSIM_CACHE_DIR`` if set (the older
    name ``$NETCOSIM_CACHE`` is still read), else ``$XDG_CACHE_HOME/netcosim``, else
    ``~/.cache/netcosim``."""
    root = os.environ.get("NETCOSIM_CACHE_DIR") or os.environ.get("NETCOSIM_CACHE")
    if root:
        return root
    return os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
                        "netcosim")


def _safe_cache_dir() -> tuple[str | None, str]:
    """``(directory, "")`` if the cache directory exists or was created (mode 0o700), is
    a real directory (not a symbolic link), is owned by the current user and is not
    writable by group or others; else ``(None, why)``.  Nobody else can then plant or
    swap a library in it."""
    root = cache_dir()
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        st = os.lstat(root)
    except OSError as exc:
        return None, f"cannot create the cache directory {root!r}: {exc}"
    if not stat.S_ISDIR(st.st_mode):
        return None, f"cache path {root!r} is not a directory (a symbolic link or a file)"
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return None, f"cache directory {root!r} is owned by uid {st.st_uid}, not by the current user {os.getuid()}"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return None, (f"cache directory {root!r} is writable by group or others (mode {stat.S_IMODE(st.st_mode):#o}); "
                      f"not loading code from it (chmod 700 it to use the cache)")
    return root, ""


def _sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _verified(lib: str) -> bool:
    """Whether *lib* is a regular file whose sha256 matches the digest recorded beside it
    (``lib + ".sha256"``) when it was built."""
    side = lib + ".sha256"
    try:
        if not (stat.S_ISREG(os.lstat(lib).st_mode) and stat.S_ISREG(os.lstat(side).st_mode)):
            return False
        with open(side) as fh:
            recorded = fh.read().strip()
        return recorded == _sha256_file(lib)
    except OSError:
        return False


def _build(cc: str, flags: list, src: str, root: str, tag: str, lib: str) -> None:
    """Compile *src* into *lib* and record the sha256 of the library in ``lib.sha256``;
    both appear atomically (built in a private temporary directory, then renamed)."""
    with tempfile.TemporaryDirectory(dir=root) as tmp:
        csrc, out = os.path.join(tmp, f"{tag}.c"), os.path.join(tmp, f"{tag}.so")
        with open(csrc, "w") as fh:
            fh.write(src)
        subprocess.run([cc, *flags, csrc, "-o", out, "-lm"], check=True, capture_output=True, timeout=300)
        side = out + ".sha256"
        with open(side, "w") as fh:
            fh.write(_sha256_file(out) + "\n")
        os.replace(out, lib)
        os.replace(side, lib + ".sha256")


def compile_functions(funs: list, tag: str) -> list:
    """The CasADi Functions *funs* compiled to one shared library, or *funs* themselves.

    The library is cached in :func:`cache_dir` under a name holding *tag* and a hash of
    its C source, the CasADi version, the compiler and its flags; the sha256 of the
    library bytes is recorded beside it at build time and checked before every load (a
    library that does not match is rebuilt, never loaded).  The directory must be
    private (see :func:`_safe_cache_dir`).  When the cache is unsafe, the compiler is
    missing or fails, or CasADi cannot load the result, the uncompiled *funs* are
    returned and a :class:`CompiledCodeWarning` is issued (once per process).
    ``COMPILE = False`` returns *funs* silently.
    """
    if not COMPILE:
        return funs
    cc_name = os.environ.get("CC") or "cc"
    cc = shutil.which(cc_name)
    if cc is None:
        warn_uncompiled(f"C compiler {cc_name!r} not found (set $CC)")
        return funs
    root, why = _safe_cache_dir()
    if root is None:
        warn_uncompiled(why)
        return funs
    flags = ["-O2", "-shared", "-fPIC"]
    try:
        cg = ca.CodeGenerator(f"{tag}.c", {"with_header": False})
        for f in funs:
            cg.add(f)
        src = cg.dump()
        key = hashlib.sha256("\n".join([src, ca.__version__, cc, *flags]).encode()).hexdigest()[:24]
        lib = os.path.join(root, f"{tag}_{key}.so")
        if not _verified(lib):
            _build(cc, flags, src, root, tag, lib)
            if not _verified(lib):
                raise OSError(f"{lib!r} changed while it was being built")
        return [ca.external(f.name(), lib) for f in funs]
    except subprocess.CalledProcessError as exc:
        err = exc.stderr.decode(errors="replace").strip()[-400:] if exc.stderr else ""
        warn_uncompiled(f"{cc} failed with exit status {exc.returncode}: {err}")
    except subprocess.TimeoutExpired as exc:
        warn_uncompiled(f"{cc} did not finish within {exc.timeout} s")
    except OSError as exc:        # compiler vanished (FileNotFoundError), unwritable cache, ...
        warn_uncompiled(f"{type(exc).__name__}: {exc}")
    except RuntimeError as exc:   # CasADi: code generation or loading the library (external)
        warn_uncompiled(f"CasADi could not generate or load the compiled code: {exc}")
    return funs
